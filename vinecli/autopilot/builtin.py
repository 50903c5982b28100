"""The built-in autopilot: estimator + PX4-style cascade + mission sequencer + safety checks.

It never touches PyBullet: each physics step it gets an
:class:`~vinecli.types.Observation` and returns rotor speed commands (rad/s) and the
sprayer flow (L/s). World ENU, body FLU, SI units. Altitudes ``*_agl_m`` of takeoff, goto,
waypoints and RTL are above home (PX4 relative altitude); the spray height is above the
terrain under the vehicle.

Modes (PX4 names, in :attr:`AutopilotStatus.mode`): ``DISARMED``, ``AUTO.TAKEOFF``,
``AUTO.LOITER`` (hold, geofence hold), ``AUTO.MISSION`` (goto, waypoints, spray),
``AUTO.LAND``, ``AUTO.RTL``, ``OPEN_LOOP``.

Events (``drain_events``): ``mode`` {mode, previous}, ``phase`` {index, type, event:
start|end}, ``arming`` {armed}, ``sprayer`` {flow_lps}, ``land_detected``, ``geofence``
{action, gf_action, violation, x, y, z}, ``status`` {status, detail}.

Safety: "cannot take off" when the collective thrust is saturated (or the rotor commands are
at >= 95 % of w_max) for ``control.cannot_takeoff_s`` while the vehicle has not climbed
0.5 m above where it armed; "lost control" when the tilt exceeds
``control.lost_control_tilt_deg``. Both end the run with that status and disarm.
Geofence breach actions follow PX4 ``GF_ACTION``: none/warn (event only), hold (loiter
where the breach happened until the run's time limit), rtl / land (then the run ends
"completed" with the breach in the detail), terminate (motors off, status
``geofence_terminated``). The fence is checked on the estimated position while airborne (on the
ground a noisy estimate near the fence is no breach; preflight keeps home and the plan a 3 σ
margin inside). A phase that exceeds its ``timeout_s`` ends the run with status ``timeout``.

Preflight (before arming, :mod:`vinecli.autopilot.preflight`): estimator converged within
``control.preflight_timeout_s``, tilt at rest, home and every planned point inside the fence
by the position-uncertainty margin and over the mapped terrain; a failure ends the run
``preflight_failed`` naming the check and the value.

Failsafes (geofence hold/rtl/land/terminate/warn; lost control; the battery at its critical state
of charge -> rtl, at its emergency one -> land, as PX4's BAT_CRIT_THR / BAT_EMERGEN_THR) switch
the sprayer off for the rest of the flight (until landed and armed again, e.g. after a refill)
and emit a ``failsafe`` event {cause, action, detail, position_est_enu}; the runner adds the true
``position_enu``. A critical battery while already returning or landing is recorded, not restarted.
"""

from __future__ import annotations

import logging
import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

from vinecli.autopilot.base import AutopilotContext, AutopilotStatus, RunStatus
from vinecli.autopilot.estimator import Estimator
from vinecli.autopilot.geofence import GF_ACTION, Geofence
from vinecli.autopilot.preflight import (
    PreflightFailure,
    check_plan,
    check_spawn_fence,
    check_tilt,
    fence_margins_m,
    plan_points,
)
from vinecli.control.cascade import Cascade, G
from vinecli.control.path import PathFollower
from vinecli.errors import AutopilotError, InputError
from vinecli.frames import Vec3, quat_to_euler, tilt_angle
from vinecli.specs.mission import (
    GotoPhase,
    HoldPhase,
    LandPhase,
    OpenLoopPhase,
    RefillSpec,
    RtlPhase,
    SprayerPhase,
    SprayPhase,
    TakeoffPhase,
    WaypointsPhase,
)
from vinecli.types import ActuatorCommand, Event, Observation, ServiceRequest

log = logging.getLogger(__name__)
_NAN = float("nan")


# ---------------------------------------------------------------------------------- phases
class _Phase(ABC):
    """One step of the mission; ``update`` runs at the position-loop rate, returns True when done."""

    mode = "AUTO.LOITER"
    type = ""
    timeout_s = math.inf

    def start(self, ap: BuiltinAutopilot) -> None:
        """Called once when the phase becomes active (default: remember when)."""
        self.t_start_us = ap.t_us

    @abstractmethod
    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        """Set the setpoints for the next ``dt`` s; True when the phase is complete."""


class _Takeoff(_Phase):
    mode = "AUTO.TAKEOFF"
    type = "takeoff"

    def __init__(self, spec: TakeoffPhase, ap: BuiltinAutopilot) -> None:
        self.spec = spec
        self.timeout_s = spec.timeout_s
        self.climb = spec.climb_speed_mps or ap.vehicle.control.max_vel_up

    def start(self, ap: BuiltinAutopilot) -> None:
        self.target_z = ap.home[2] + self.spec.altitude_agl_m
        self.spool = 0.0
        if ap.armed:
            x, y, _ = ap.hold_sp()
        else:
            x, y = ap.pos[0], ap.pos[1]
        self.xy = (x, y)
        self.path: PathFollower | None = None

    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        if not ap.armed:
            if not ap.preflight_ok():
                return False
            ap.arm()
        if self.path is None:
            self.spool += dt
            ap.set_position((self.xy[0], self.xy[1], ap.pos[2] - 0.3), (0.0, 0.0, 0.0))
            if self.spool < ap.spool_s and not ap.airborne:
                ap.cascade.reset()
                ap.idle = True
                return False
            ap.idle = False
            z0 = min(ap.pos[2], self.target_z)
            self.path = PathFollower([(self.xy[0], self.xy[1], z0), (self.xy[0], self.xy[1], self.target_z)],
                                     self.climb, accel=2.0, acceptance_m=self.spec.tolerance_m, max_lead_m=1.0,
                                     max_up=self.climb)
        sp, vff, _ = self.path.update(dt, ap.pos)
        if not ap.airborne:
            ap.cascade.reset_rate_integrators()
        ap.set_position(sp, vff, aff=self.path.aff)
        return self.path.s >= self.path.total and abs(ap.pos[2] - self.target_z) <= self.spec.tolerance_m


class _Hold(_Phase):
    mode = "AUTO.LOITER"
    type = "hold"

    def __init__(self, duration_s: float) -> None:
        self.duration = duration_s
        self.timeout_s = duration_s + 1.0

    def start(self, ap: BuiltinAutopilot) -> None:
        self.t = 0.0
        self.sp = ap.hold_sp()

    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        self.t += dt
        ap.set_position(self.sp, (0.0, 0.0, 0.0))
        return self.t >= self.duration - 1e-9


class _Loiter(_Phase):
    """Hold forever (geofence 'hold' action)."""

    mode = "AUTO.LOITER"
    type = "loiter"

    def start(self, ap: BuiltinAutopilot) -> None:
        # brake: hold the current position estimate
        self.sp = (ap.pos[0], ap.pos[1], ap.pos[2])

    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        ap.set_position(self.sp, (0.0, 0.0, 0.0))
        return False


class _Path(_Phase):
    """Goto / waypoints: follow a polyline of absolute ENU points."""

    mode = "AUTO.MISSION"

    def __init__(self, type_: str, make: Callable[[BuiltinAutopilot], PathFollower], timeout_s: float,
                 flow: float | None = None, yaw_deg: float | None = None) -> None:
        self.type = type_
        self.make = make
        self.timeout_s = timeout_s
        self.flow = flow
        self.yaw_deg = yaw_deg

    def start(self, ap: BuiltinAutopilot) -> None:
        self.path = self.make(ap)
        if self.flow is not None:
            ap.set_flow(self.flow)
        if self.yaw_deg is not None:
            ap.cascade.set_yaw(math.radians(self.yaw_deg))

    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        sp, vff, done = self.path.update(dt, ap.pos)
        ap.set_position(sp, vff, aff=self.path.aff)
        return done


class _Service(_Phase):
    """On the ground, disarmed: the crew refills the tank (and swaps the battery) in ``time_s``."""

    mode = "AUTO.LOITER"
    type = "service"

    def __init__(self, spec: RefillSpec, fill_l: float) -> None:
        self.spec = spec
        self.fill_l = fill_l

    def start(self, ap: BuiltinAutopilot) -> None:
        self.t = 0.0
        self.requested = False

    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        self.t += dt
        if self.t < self.spec.time_s:
            return False
        if not self.requested:
            ap.request_service(ServiceRequest(self.fill_l, self.spec.swap_battery))
            self.requested = True
            return False
        return ap.tank_level_l >= self.fill_l - 1e-6


class _Spray(_Phase):
    type = "spray"

    def __init__(self, spec: SprayPhase, rows: list[list[tuple[float, float]]]) -> None:
        self.spec = spec
        self.rows = rows
        self.timeout_s = spec.timeout_s
        self.sortie = 1
        self.sub: _Phase | None = None  # return / service / take-off between sorties
        self._queue: list[_Phase] = []
        self._resume: tuple[list[Vec3], list[float]] | None = None
        self._left_at_last_end = math.inf  # path length left when the last sortie ended, m

    @property
    def mode(self) -> str:  # type: ignore[override]
        """The sortie step's mode while one runs, else AUTO.MISSION."""
        return self.sub.mode if self.sub is not None else "AUTO.MISSION"

    def _passes(self, ap: BuiltinAutopilot, start_xy: tuple[float, float]) -> tuple[list[Vec3], list[float]]:
        """The operator plan from ``start_xy`` (:func:`~vinecli.rows.plan.plan_rows`: nearest row
        first, boustrophedon, headland turns from the speed and acceleration, rows clipped to the geofence
        with a 1 m margin); flow on over the rows only. ``until: empty`` replans from the last row's end,
        so the rows are flown back."""
        from vinecli.rows.plan import plan_rows

        fence = ap.geofence.spec.polygon_enu if ap.geofence is not None and ap.geofence.spec.polygon_enu else None
        plan = plan_rows(self.rows, start_xy, speed_mps=self.spec.speed_mps, accel_mps2=self.accel(ap),
                         fence_enu=fence)
        if not plan.legs:
            raise InputError("spray phase: no rows left inside the geofence")
        if not self.announced:
            ap.emit("spray_plan", plan.summary(), {"rows": plan.order, "length_m": round(plan.length_m, 2),
                                                   "time_s": plan.time_s, "warnings": plan.warnings})
            self.announced = True
        pts2, flows = plan.path(self.spec.flow_lps)
        h = self.spec.height_agl_m
        return [(x, y, h) for x, y in pts2], flows

    @staticmethod
    def accel(ap: BuiltinAutopilot) -> float:
        """Acceleration of the spray path (m/s², the one the plans assume)."""
        from vinecli.rows.plan import plan_accel

        return plan_accel(ap.vehicle)

    def start(self, ap: BuiltinAutopilot) -> None:
        self.announced = False
        self._new_path(ap)

    # ---- sorties (refill jobs)
    @staticmethod
    def _sortie_over(ap: BuiltinAutopilot, refill: RefillSpec) -> str:
        """Why this sortie must end now ('' = it goes on): tank at the reserve, battery low."""
        if ap.vehicle.tank is not None and ap.tank_level_l <= max(refill.reserve_l, 1e-6):
            return "tank empty" if refill.reserve_l <= 0.0 else f"tank at the {refill.reserve_l:g} L reserve"
        bat = ap.vehicle.battery
        if refill.swap_battery and bat is not None and ap.battery_soc <= bat.low_soc:
            return f"battery at {ap.battery_soc * 100:.0f} % (low {bat.low_soc * 100:.0f} %)"
        return ""

    def _last_sortie(self, ap: BuiltinAutopilot, why: str, reason: str) -> bool:
        """End the job in this sortie (event ``sortie`` with ``last``), sprayer off; True (phase done)."""
        ap.emit("sortie", f"sortie {self.sortie} ends {why}",
                {"sortie": self.sortie, "event": "end", "reason": reason, "last": True})
        ap.set_flow(0.0)
        return True

    def _end_sortie(self, ap: BuiltinAutopilot, refill: RefillSpec, reason: str) -> None:
        """Record the breakpoint, then return, land, get serviced and take off again."""
        ap.set_flow(0.0)
        bp = self.path.sp
        self._resume = self.path.remaining(refill.overlap_m)
        ap.emit("sortie", f"sortie {self.sortie} ends ({reason}) at breakpoint ({bp[0]:.1f}, {bp[1]:.1f})",
                {"sortie": self.sortie, "event": "end", "reason": reason, "breakpoint_enu": [bp[0], bp[1], bp[2]]})
        tank = ap.vehicle.tank
        fill = refill.fill_l if refill.fill_l is not None else (tank.capacity_l if tank is not None else 0.0)
        up = TakeoffPhase(altitude_agl_m=self.spec.height_agl_m)
        self._queue = [_Rtl(refill.return_altitude_agl_m, math.inf), _Service(refill, fill), _Takeoff(up, ap)]
        self._next_step(ap)

    def _next_step(self, ap: BuiltinAutopilot) -> None:
        if self._queue:
            self.sub = self._queue.pop(0)
            self.sub.start(ap)
            return
        self.sub = None
        self.sortie += 1
        ap.sortie = self.sortie
        ap.emit("sortie", f"sortie {self.sortie} starts", {"sortie": self.sortie, "event": "start"})
        self._new_path(ap, resume=self._resume)

    def _new_path(self, ap: BuiltinAutopilot, resume: tuple[list[Vec3], list[float]] | None = None) -> None:
        if resume is None:
            pts, flows = self._passes(ap, (ap.hold_sp()[0], ap.hold_sp()[1]))
        else:  # from where the vehicle is to the breakpoint (flow off), then the rest of the rows
            h = self.spec.height_agl_m
            pts = [(ap.hold_sp()[0], ap.hold_sp()[1], h), *resume[0]]
            flows = [0.0, *resume[1]]
        terrain, lgh = ap.terrain, ap.vehicle.frame.landing_gear_height_m

        def skids_above_terrain(x: float, y: float) -> float:
            return terrain(x, y) + lgh  # the height is the skids' (as the recorded height_agl_m)

        self.path = PathFollower(pts, self.spec.speed_mps, accel=self.accel(ap), flows=flows, terrain=skids_above_terrain,
                                 acceptance_m=0.7,
                                 max_lead_m=2.0, max_vz=min(ap.vehicle.control.max_vel_up, ap.vehicle.control.max_vel_down))

    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        if self.sub is not None:
            if self.sub.update(ap, dt):
                self._next_step(ap)
            return False
        refill = self.spec.refill
        if refill is not None:
            reason = self._sortie_over(ap, refill)
            if reason:
                if self.sortie >= refill.max_sorties:
                    return self._last_sortie(ap, f"({reason}): max_sorties {refill.max_sorties} reached", reason)
                left = self.path.total - self.path.s
                if left >= self._left_at_last_end - 0.5:
                    return self._last_sortie(ap, f"({reason}) before reaching new rows: job aborted",
                                             f"no progress ({reason})")
                self._left_at_last_end = left
                self._end_sortie(ap, refill, reason)
                return False
        if ap.tank_empty:
            ap.set_flow(0.0)
            ap.set_position(ap.hold_sp(), (0.0, 0.0, 0.0))
            return True
        sp, vff, done = self.path.update(dt, ap.pos)
        ap.set_position(sp, vff, aff=self.path.aff)
        # spray only when the vehicle itself is at the carrot (not while catching up)
        near = math.hypot(sp[0] - ap.pos[0], sp[1] - ap.pos[1]) < 0.7 and abs(sp[2] - ap.pos[2]) < 0.7
        ap.set_flow(self.path.flow if near else 0.0)
        if done:
            if self.spec.until == "empty":
                self._new_path(ap)
                return False
            ap.set_flow(0.0)
            return True
        return False


class _Sprayer(_Phase):
    type = "sprayer"

    def __init__(self, flow: float) -> None:
        self.flow = flow

    def start(self, ap: BuiltinAutopilot) -> None:
        self.mode = ap.mode  # instantaneous, no mode change
        ap.set_flow(self.flow)

    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        if ap.armed:
            ap.set_position(ap.hold_sp(), (0.0, 0.0, 0.0))
        return True


class _Land(_Phase):
    mode = "AUTO.LAND"
    type = "land"

    def __init__(self, descent: float, timeout_s: float) -> None:
        self.descent = descent
        self.timeout_s = timeout_s

    def start(self, ap: BuiltinAutopilot) -> None:
        sp = ap.hold_sp()
        self.xy = (sp[0], sp[1])
        self.z = sp[2]
        self.t_landed = 0.0
        self.t = 0.0

    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        if not ap.armed:
            return True
        # velocity-controlled descent, position hold horizontally
        self.z -= self.descent * dt
        ap.set_position((self.xy[0], self.xy[1], self.z), (0.0, 0.0, -self.descent), z_velocity_only=True)
        hover = ap.mass * G
        low_thrust = ap.cascade.thrust_sp < 0.6 * hover
        slow = abs(ap.vel[2]) < 0.25
        self.t += dt
        if self.t > 1.0 and slow and (low_thrust or ap.ground_contact):
            self.t_landed += dt
        else:
            self.t_landed = 0.0
        if self.t_landed >= 0.4:
            ap.emit("land_detected", "touchdown detected", {"x": ap.pos[0], "y": ap.pos[1], "z": ap.pos[2]})
            ap.disarm()
            return True
        return False


class _Rtl(_Phase):
    mode = "AUTO.RTL"
    type = "rtl"

    def __init__(self, return_alt: float, timeout_s: float, descent: float = 0.7) -> None:
        self.return_alt = return_alt
        self.timeout_s = timeout_s
        self.descent = descent

    def start(self, ap: BuiltinAutopilot) -> None:
        x, y, z = ap.hold_sp() if ap.armed else ap.pos
        h = ap.home
        zr = max(z, h[2] + self.return_alt)
        speed = min(5.0, ap.vehicle.control.max_vel_xy)
        pts = [(x, y, z), (x, y, zr), (h[0], h[1], zr)]
        c = ap.vehicle.control
        self.path = PathFollower(pts, speed, accel=2.0, acceptance_m=0.5, max_up=c.max_vel_up, max_down=c.max_vel_down)
        self.land: _Land | None = None

    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        if not ap.armed:
            return True
        if self.land is None:
            sp, vff, done = self.path.update(dt, ap.pos)
            ap.set_position(sp, vff, aff=self.path.aff)
            if done:
                self.land = _Land(self.descent, math.inf)
                self.land.start(ap)
            return False
        return self.land.update(ap, dt)


class _OpenLoop(_Phase):
    mode = "OPEN_LOOP"
    type = "open_loop"

    def __init__(self, spec: OpenLoopPhase, n: int) -> None:
        self.spec = spec
        self.n = n
        self.timeout_s = spec.duration_s + 1.0
        if spec.rotor_speeds_rad_s is not None:
            self.schedule = [(0.0, self._speeds(spec.rotor_speeds_rad_s))]
        else:
            self.schedule = [(float(t), self._speeds(s)) for t, s in sorted(spec.schedule or [], key=lambda e: e[0])]
        self.times_us = [int(round(t * 1e6)) for t, _ in self.schedule]
        self.duration_us = int(round(spec.duration_s * 1e6))

    def _speeds(self, s: float | list[float]) -> tuple[float, ...]:
        if isinstance(s, int | float):
            return (float(s),) * self.n
        if len(s) != self.n:
            raise InputError(f"open_loop: {len(s)} rotor speeds given for a vehicle with {self.n} rotors")
        return tuple(float(v) for v in s)

    def start(self, ap: BuiltinAutopilot) -> None:
        self.t0_us = ap.t_us
        self.i = 0
        # before the first breakpoint the rotors keep the previous command (rad/s); a mission that
        # starts airborne spins them at the first breakpoint's speeds (the runner's initial state)
        init = self.spec.initial_state
        airborne = init is not None and init.position_enu is not None and init.position_enu[2] > 0.0
        self.before = self.schedule[0][1] if airborne else tuple(ap.rotor_command)
        ap.set_flow(self.spec.flow_lps)
        if not ap.armed:
            ap.arm()

    def command(self, t_us: int) -> tuple[tuple[float, ...], bool]:
        """(rotor speeds, done) at time t_us (breakpoints compared in integer µs, no float drift)."""
        t = t_us - self.t0_us
        times = self.times_us
        while self.i + 1 < len(times) and t >= times[self.i + 1]:
            self.i += 1
        speeds = self.schedule[self.i][1] if t >= times[0] else self.before
        return speeds, t >= self.duration_us

    def update(self, ap: BuiltinAutopilot, dt: float) -> bool:
        return False


# ---------------------------------------------------------------------------------- autopilot
class BuiltinAutopilot:
    """The built-in backend of the :class:`~vinecli.autopilot.base.Autopilot` protocol.

    Options: ``truth`` (bool, default: the mission's ``truth``) uses ground truth instead
    of the estimator.
    """

    name = "builtin"

    def __init__(self, *, truth: bool | None = None, **opts: Any) -> None:
        if opts:
            raise InputError(f"builtin autopilot: unknown option(s) {', '.join(sorted(opts))}")
        self._truth_opt = truth
        self._status = AutopilotStatus(mode="DISARMED", phase_index=0)
        self._events: list[Event] = []
        self._ctx: AutopilotContext | None = None

    # ------------------------------------------------------------------ protocol
    def reset(self, ctx: AutopilotContext) -> None:
        """Build estimator, controller and the phase list for ``ctx.mission``."""
        self._ctx = ctx
        self.vehicle = v = ctx.vehicle
        self.mission = ctx.mission
        if ctx.physics_dt_us <= 0:
            raise AutopilotError(f"invalid physics step {ctx.physics_dt_us} µs")
        self.dt = ctx.physics_dt_us * 1e-6
        self.truth = bool(ctx.mission.truth if self._truth_opt is None else self._truth_opt)
        self.cascade = Cascade(v, self.dt)
        self.n_pos = max(1, round(1.0 / (self.dt * v.control.pos_loop_rate_hz)))
        self.dt_pos = self.n_pos * self.dt
        self.estimator = None if self.truth else Estimator(v, ctx.origin)
        self.home: Vec3 = tuple(float(c) for c in ctx.home_enu)  # type: ignore[assignment]
        th = ctx.terrain_height
        if th is None:
            hz = self.home[2] - v.frame.landing_gear_height_m

            def _flat(x: float, y: float) -> float:
                return hz

            self.terrain: Callable[[float, float], float] = _flat
        else:
            self.terrain = th  # type: ignore[assignment]
        self.geofence = Geofence(ctx.geofence, self.home) if ctx.geofence is not None else None
        self.cos_lost = math.cos(math.radians(v.control.lost_control_tilt_deg))
        self.spool_s = 0.5
        self.phases = [self._make_phase(p, ctx) for p in ctx.mission.phases]
        self._plan_failures = self._mission_preflight(ctx)
        # state
        self.t_us = 0
        self.pos: Vec3 = self.home
        self.vel: Vec3 = (0.0, 0.0, 0.0)
        self.quat = (0.0, 0.0, 0.0, 1.0)
        self.omega: Vec3 = (0.0, 0.0, 0.0)
        self.est_ready = self.truth
        self.armed = False
        self.idle = False
        self.airborne = False
        self.ground_contact = True
        self.height_terrain = 0.0
        self.flow = 0.0
        self.mass = ctx.total_mass_kg
        self._dry_mass: float | None = None
        self.tank_empty = False
        self.tank_level_l = 0.0
        self.battery_soc = math.nan
        self.sortie = 1
        self._service: ServiceRequest | None = None
        self.mode = "DISARMED"
        self._phase_i = -1
        self._phase: _Phase | None = None
        self._phase_t = 0.0
        self._failsafe = False
        self._failsafe_detail = ""
        self._battery_level = 0  # 0 ok, 1 critical (returning), 2 emergency (landing)
        self.sprayer_inhibited = False
        self._countdown = 0
        self._z_armed = self.home[2]
        self._sat_t = 0.0
        self._sp: Vec3 | None = None
        self._w_cmd: tuple[float, ...] = (0.0,) * v.n_rotors
        self._off = ActuatorCommand((0.0,) * v.n_rotors, 0.0, False)
        self._status = AutopilotStatus(mode="DISARMED", phase_index=0,
                                       extra={"sp_x": _NAN, "sp_y": _NAN, "sp_z": _NAN, "mass_est_kg": self.mass,
                                              "sortie": 1.0})
        self._events = []
        self._next_phase()

    def replace_phases(self, phases: list[object]) -> None:
        """Replace the remaining mission by ``phases`` (mission phase specs) and start the first
        one now (run-time missions, e.g. uploaded over MAVLink). Raises InputError for bad phases."""
        ctx = self._ctx
        if ctx is None:
            raise AutopilotError("replace_phases before reset")
        self.phases = [self._make_phase(p, ctx) for p in phases]
        self._phase_i = -1
        self._failsafe = False
        self._countdown = 0
        self._next_phase()

    def _make_phase(self, p: object, ctx: AutopilotContext) -> _Phase:
        v = ctx.vehicle
        if isinstance(p, TakeoffPhase):
            return _Takeoff(p, self)
        if isinstance(p, HoldPhase):
            return _Hold(p.duration_s)
        if isinstance(p, GotoPhase):
            g = p

            def make_goto(ap: BuiltinAutopilot) -> PathFollower:
                x, y, z = ap.hold_sp()
                zt = ap.home[2] + g.altitude_agl_m if g.altitude_agl_m is not None else z
                speed = g.speed_mps or min(5.0, v.control.max_vel_xy)
                return PathFollower([(x, y, z), (g.position_enu[0], g.position_enu[1], zt)], speed,
                                    acceptance_m=g.acceptance_radius_m, max_up=v.control.max_vel_up,
                                    max_down=v.control.max_vel_down)

            return _Path("goto", make_goto, p.timeout_s, yaw_deg=p.yaw_deg)
        if isinstance(p, WaypointsPhase):
            w = p

            def make_wp(ap: BuiltinAutopilot) -> PathFollower:
                pts = [ap.hold_sp()] + [(x, y, ap.home[2] + a) for x, y, a in w.waypoints]
                fl = [w.flow_lps if w.flow_lps is not None else ap.flow] * (len(pts) - 1)
                return PathFollower(pts, w.speed_mps, acceptance_m=w.acceptance_radius_m, flows=fl,
                                    max_up=v.control.max_vel_up, max_down=v.control.max_vel_down)

            return _Path("waypoints", make_wp, p.timeout_s, flow=p.flow_lps)
        if isinstance(p, SprayPhase):
            return _Spray(p, self._spray_rows(p, ctx))
        if isinstance(p, SprayerPhase):
            return _Sprayer(p.flow_lps)
        if isinstance(p, LandPhase):
            return _Land(p.descent_speed_mps, p.timeout_s)
        if isinstance(p, RtlPhase):
            return _Rtl(p.return_altitude_agl_m, p.timeout_s)
        if isinstance(p, OpenLoopPhase):
            return _OpenLoop(p, v.n_rotors)
        raise InputError(f"builtin autopilot: unsupported phase {type(p).__name__}")

    @staticmethod
    def _spray_rows(p: SprayPhase, ctx: AutopilotContext) -> list[list[tuple[float, float]]]:
        world_rows = [[(float(x), float(y)) for x, y in r] for r in ctx.vine_rows_enu]
        if p.rows == "world":
            rows = world_rows
        elif p.rows and all(isinstance(r, int) for r in p.rows):
            bad = [i for i in p.rows if not 0 <= int(i) < len(world_rows)]  # type: ignore[arg-type]
            if bad:
                raise InputError(f"spray phase: row index {bad[0]} out of range (the world has {len(world_rows)} rows)")
            rows = [world_rows[int(i)] for i in p.rows]  # type: ignore[arg-type]
        else:
            rows = [[(float(x), float(y)) for x, y in r] for r in p.rows]  # type: ignore[union-attr, misc]
        rows = [r for r in rows if len(r) >= 2]
        if not rows:
            raise InputError("spray phase: no vine rows to spray (the world has none and the phase gives none)")
        return rows

    def step(self, obs: Observation) -> ActuatorCommand:
        """Commands for the next physics step."""
        st = self._status
        if st.status is not RunStatus.RUNNING:
            return self._off
        self.t_us = obs.t_us
        if self.truth:
            tr = obs.truth
            self.pos, self.vel, self.quat, self.omega = tr.pos, tr.vel, tr.quat, tr.omega_body
        else:
            est = self.estimator
            est.update(obs)  # type: ignore[union-attr]
            self.pos, self.vel, self.quat, self.omega = est.pos, est.vel, est.quat, est.omega  # type: ignore[union-attr]
            self.est_ready = est.ready  # type: ignore[union-attr]
        self.ground_contact = obs.truth.on_ground
        self.height_terrain = self.pos[2] - obs.terrain_height_m - self.vehicle.frame.landing_gear_height_m
        return self._command(obs)

    def _command(self, obs: Observation) -> ActuatorCommand:
        ph = self._phase
        if isinstance(ph, _OpenLoop):
            w, done = ph.command(obs.t_us)
            if not done:
                self._w_cmd = w
                return ActuatorCommand(w, self.flow, True)
            self._end_phase()
            if self._status.status is not RunStatus.RUNNING:
                return self._off
            self._countdown = 0
            if isinstance(self._phase, _OpenLoop):
                return self._command(obs)
            # the controller takes over from the current state
            self.cascade.reset()
            self.cascade.set_yaw(quat_to_euler(self.quat)[2], immediate=True)
            self._sp = None
            if self._phase is not None:
                self._phase.start(self)
        return self._controller(obs)

    def _controller(self, obs: Observation) -> ActuatorCommand:
        """Sequencer (position-loop rate) + attitude/rate loops (every step)."""
        self._countdown -= 1
        if self._countdown <= 0:
            self._countdown = self.n_pos
            self._outer(obs)
            if self._status.status is not RunStatus.RUNNING:
                return self._off
            if isinstance(self._phase, _OpenLoop):
                return self._command(obs)
        if not self.armed:
            if self._service is not None:  # the ground crew's turn (refill sorties)
                req, self._service = self._service, None
                return ActuatorCommand(self._off.rotor_speed_cmd, 0.0, False, req)
            return self._off
        q = self.quat
        if 1.0 - 2.0 * (q[0] * q[0] + q[1] * q[1]) < self.cos_lost:
            tilt = math.degrees(tilt_angle(q))
            detail = f"tilt {tilt:.0f} deg beyond {self.vehicle.control.lost_control_tilt_deg:g} deg"
            self.failsafe("lost_control", "disarm", detail)
            self._finish(RunStatus.LOST_CONTROL, detail)
            return self._off
        if self.idle:
            wi = self.vehicle.motor.w_min_armed
            self._w_cmd = (wi,) * self.vehicle.n_rotors
            return ActuatorCommand(self._w_cmd, self.flow, True)
        w = self.cascade.update_attitude(q, self.omega, self.dt)
        self._w_cmd = w
        return ActuatorCommand(w, self.flow, True)

    def status(self) -> AutopilotStatus:
        """Current mode/phase; ``extra`` has the position setpoint sp_x, sp_y, sp_z (ENU m)."""
        return self._status

    def drain_events(self) -> list[Event]:
        """Events since the last call."""
        ev, self._events = self._events, []
        return ev

    def close(self) -> None:
        """Nothing to release (idempotent)."""

    # ------------------------------------------------------------------ preflight
    def _mission_preflight(self, ctx: AutopilotContext) -> list[PreflightFailure]:
        """Checks that depend only on the mission and the world (fence margins, plan over the terrain)."""
        v = ctx.vehicle
        margins = fence_margins_m(v, truth=self.truth)
        out: list[PreflightFailure] = []
        spawn = check_spawn_fence(ctx.geofence, self.home, margins[0])
        if spawn is not None:
            out.append(spawn)
        pts = plan_points(ctx.mission, self.home, ctx.vine_rows_enu, self.terrain, v.frame.landing_gear_height_m)
        out += check_plan(pts, ctx.geofence, self.home, margins, ctx.terrain_bounds)
        return out

    def preflight_ok(self) -> bool:
        """PX4-style arming checks; True when the vehicle may arm now. False while the estimator
        settles; a failed check ends the run ``preflight_failed`` (event ``preflight``)."""
        if not self.est_ready:
            limit = self.vehicle.control.preflight_timeout_s
            if self.t_us * 1e-6 >= limit:
                reason = self.estimator.not_ready_reason if self.estimator is not None else ""
                self._preflight_fail(PreflightFailure(
                    "estimator", self.t_us * 1e-6, limit,
                    f"preflight check 'estimator': not converged after {limit:g} s ({reason})"))
            return False
        tilt = check_tilt(tilt_angle(self.quat), self.vehicle)
        failures = ([tilt] if tilt is not None else []) + self._plan_failures
        if failures:
            self._preflight_fail(failures[0])
            return False
        return True

    def _preflight_fail(self, f: PreflightFailure) -> None:
        self.emit("preflight", f.message, {"check": f.check, "value": f.value, "limit": f.limit})
        log.warning("%s", f.message)
        self._finish(RunStatus.PREFLIGHT_FAILED, f.message)

    # ------------------------------------------------------------------ failsafes
    def failsafe(self, cause: str, action: str, detail: str) -> None:
        """Record a failsafe and switch the sprayer off for the rest of the flight (event ``failsafe``)."""
        self.set_flow(0.0)
        self.sprayer_inhibited = True
        p = self.pos
        self.emit("failsafe", f"{detail} at {self.t_us * 1e-6:.2f} s → {action}; sprayer off",
                  {"cause": cause, "action": action, "detail": detail, "position_est_enu": [p[0], p[1], p[2]]})
        log.warning("failsafe: %s at %.2f s → %s; sprayer off", detail, self.t_us * 1e-6, action)

    # ------------------------------------------------------------------ helpers used by phases
    def emit(self, kind: str, message: str, data: dict[str, object] | None = None) -> None:
        """Queue an event at the current time."""
        self._events.append(Event(self.t_us, kind, message, data or {}))

    def arm(self) -> None:
        """Arm (motors idle); a new flight: a failsafe's sprayer lock-out of the previous one ends."""
        if not self.armed:
            self.armed = True
            self.sprayer_inhibited = False
            self._battery_level = 0  # a new flight (after a refill: a swapped battery)
            self._z_armed = self.pos[2]
            self.cascade.reset()
            self.cascade.set_yaw(quat_to_euler(self.quat)[2], immediate=True)
            self._sat_t = 0.0
            self.emit("arming", "armed", {"armed": True})

    def disarm(self) -> None:
        if self.armed:
            self.armed = False
            self.airborne = False
            self.set_flow(0.0)
            self._sp = None
            ex = self._status.extra
            ex["sp_x"] = ex["sp_y"] = ex["sp_z"] = _NAN
            self.emit("arming", "disarmed", {"armed": False})
            self._set_mode("DISARMED")

    @property
    def rotor_command(self) -> tuple[float, ...]:
        """The last rotor speed command, rad/s per rotor (zeros before the first)."""
        return self._w_cmd

    def request_service(self, req: ServiceRequest) -> None:
        """Ask the ground crew (the simulator) to refill / swap the battery; only honoured while
        disarmed on the ground."""
        self._service = req
        self.emit("service", f"refill to {req.fill_l:g} L" + (", battery swap" if req.swap_battery else ""),
                  {"fill_l": req.fill_l, "swap_battery": req.swap_battery})

    def set_flow(self, flow: float) -> None:
        """Sprayer flow command, L/s (held at 0 after a failsafe)."""
        if self.sprayer_inhibited:
            flow = 0.0
        if flow != self.flow:
            self.flow = flow
            self.emit("sprayer", f"sprayer flow {flow:g} L/s", {"flow_lps": flow})

    def hold_sp(self) -> Vec3:
        """Where to hold: the last position setpoint, else the current estimate."""
        return self._sp if self._sp is not None else self.pos

    def set_position(self, sp: Vec3, vff: Vec3, *, z_velocity_only: bool = False, aff: Vec3 = (0.0, 0.0, 0.0)) -> None:
        """Position setpoint (ENU m) with velocity (m/s) and acceleration (m/s²) feed-forward."""
        c = self.cascade
        c.pos_sp = sp
        c.vel_ff = vff
        c.acc_ff = aff
        c.xy_pos_ctrl = True
        c.z_pos_ctrl = not z_velocity_only
        self._sp = sp

    def _set_mode(self, mode: str) -> None:
        if mode != self.mode:
            self.emit("mode", mode, {"mode": mode, "previous": self.mode})
            self.mode = mode
            self._status.mode = mode

    def _finish(self, status: RunStatus, detail: str) -> None:
        st = self._status
        if st.status is not RunStatus.RUNNING:
            return
        if self.armed and status in (RunStatus.CANNOT_TAKE_OFF, RunStatus.LOST_CONTROL, RunStatus.GEOFENCE_TERMINATED):
            self.disarm()  # motors off; a completed or timed-out run just ends where it is
        st.status = status
        st.detail = detail
        self.emit("status", f"{status.value}: {detail}", {"status": status.value, "detail": detail})
        log.info("run ends: %s (%s)", status.value, detail)

    def _next_phase(self) -> None:
        self._phase_i += 1
        if self._phase_i >= len(self.phases):
            self._phase = None
            self._finish(RunStatus.COMPLETED, "all phases completed")
            return
        ph = self.phases[self._phase_i]
        self._phase = ph
        self._phase_t = 0.0
        self._status.phase_index = self._phase_i
        self.emit("phase", f"phase {self._phase_i} ({ph.type}) start",
                  {"index": self._phase_i, "type": ph.type, "event": "start"})
        ph.start(self)
        self._set_mode(ph.mode if (self.armed or isinstance(ph, _OpenLoop)) else self.mode)

    def _end_phase(self) -> None:
        ph = self._phase
        if ph is None:
            return
        if self._failsafe:
            self._phase = None
            self._finish(RunStatus.COMPLETED, self._failsafe_detail)
            return
        self.emit("phase", f"phase {self._phase_i} ({ph.type}) end", {"index": self._phase_i, "type": ph.type, "event": "end"})
        self._next_phase()

    def _failsafe_to(self, ph: _Phase, detail: str) -> None:
        self._failsafe = True
        self._failsafe_detail = detail
        self._phase = ph
        self._phase_t = 0.0
        ph.start(self)
        self._set_mode(ph.mode)

    # ------------------------------------------------------------------ outer loop (position-loop rate)
    def _outer(self, obs: Observation) -> None:
        dt = self.dt_pos
        v = self.vehicle
        # mass estimate: dry mass + liquid in the tank
        level = obs.tank_level_l
        if self._dry_mass is None:
            self._dry_mass = self._ctx.total_mass_kg - v.liquid_mass(level)  # type: ignore[union-attr]
        self.mass = self._dry_mass + v.liquid_mass(level)
        self.tank_empty = v.tank is not None and level <= 1e-6
        self.tank_level_l = level
        self.battery_soc = obs.battery_soc
        h_agl = self.pos[2] - self._z_armed
        if self.armed and not self.airborne and self.height_terrain > 0.2 and not self.ground_contact:
            self.airborne = True
        # safety checks
        if self.armed and not isinstance(self._phase, _OpenLoop) and not self.idle:
            c = self.cascade
            w_max = v.motor.w_max
            near_max = sum(self._w_cmd) >= 0.95 * w_max * len(self._w_cmd)
            if (c.thrust_saturated > 0 or near_max) and h_agl < 0.5 and self.vel[2] < 0.3:
                self._sat_t += dt
                if self._sat_t >= v.control.cannot_takeoff_s:
                    self._finish(RunStatus.CANNOT_TAKE_OFF,
                                 f"thrust-limited for {self._sat_t:.1f} s at {h_agl:.2f} m above the start "
                                 f"(weight {self.mass * G:.1f} N, max thrust {v.max_thrust():.1f} N)")
                    return
            else:
                self._sat_t = 0.0
        if self.geofence is not None and self.armed and self.airborne:
            viol = self.geofence.check(self.pos)
            if viol and self._failsafe:
                log.debug("geofence breach (%s) during the failsafe: no new action", viol)
            elif viol:
                self._on_geofence(viol)
                if self._status.status is not RunStatus.RUNNING:
                    return
        soc = obs.battery_soc
        if soc == soc and self.armed and self.airborne and self.vehicle.battery is not None:  # NaN: no battery model
            self._check_battery(soc)
        # sequencer
        ph = self._phase
        if ph is not None:
            self._phase_t += dt
            if self._phase_t > ph.timeout_s:
                self._finish(RunStatus.TIMEOUT, f"phase {self._phase_i} ({ph.type}) timed out after {ph.timeout_s:g} s")
                return
            if ph.update(self, dt):
                self._end_phase()
                if self._status.status is not RunStatus.RUNNING:
                    return
                if self._phase is not None and not isinstance(self._phase, _OpenLoop):
                    self._phase.update(self, 0.0)
            if self.armed and self._phase is not None and self.mode != self._phase.mode:
                self._set_mode(self._phase.mode)
        if self.armed and not self.idle:
            self.cascade.update_position(self.pos, self.vel, self.mass, dt)
        ex = self._status.extra
        sp = self._sp
        if sp is None or not self.armed:
            ex["sp_x"] = ex["sp_y"] = ex["sp_z"] = _NAN
        else:
            ex["sp_x"], ex["sp_y"], ex["sp_z"] = sp
        ex["mass_est_kg"] = self.mass
        ex["sortie"] = float(self.sortie)

    def _check_battery(self, soc: float) -> None:
        """PX4 BAT_CRIT_THR / BAT_EMERGEN_THR: return to launch at the critical state of charge, land
        where it is at the emergency one (each once per flight; a return or landing in progress goes on)."""
        b = self.vehicle.battery
        if b is None:
            return
        level = 2 if soc < b.emergency_soc else 1 if soc < b.critical_soc else 0  # a level of 0 is off
        if level <= self._battery_level:
            return
        self._battery_level = level
        name = "emergency" if level == 2 else "critical"
        limit = b.emergency_soc if level == 2 else b.critical_soc
        detail = f"battery {soc:.1%} below the {name} level {limit:.0%}"
        if self.mode in ("AUTO.RTL", "AUTO.LAND") and (level == 1 or self.mode == "AUTO.LAND"):
            # already returning (a refill sortie's return) or landing: PX4 does not restart it
            self.failsafe("low_battery", "rtl" if self.mode == "AUTO.RTL" else "land", detail)
        elif level == 2:
            self.failsafe("low_battery", "land", detail)
            self._sp = None  # land where the vehicle is
            self._failsafe_to(_Land(0.7, math.inf), f"low battery ({detail}): landed")
        else:
            self.failsafe("low_battery", "rtl", detail)
            self._failsafe_to(_Rtl(5.0, math.inf), f"low battery ({detail}): returned to launch and landed")

    def _on_geofence(self, violation: str) -> None:
        action = self.geofence.action  # type: ignore[union-attr]
        p = self.pos
        self.emit("geofence", f"geofence breach ({violation}): action {action}",
                  {"action": action, "gf_action": GF_ACTION[action], "violation": violation,
                   "x": p[0], "y": p[1], "z": p[2]})
        if action == "none":
            log.info("geofence breach (%s) at %.1f %.1f %.1f: no action", violation, p[0], p[1], p[2])
            return
        self.failsafe("geofence", action, f"geofence breach ({violation})")
        if action == "warn":
            return
        if action == "terminate":
            self._finish(RunStatus.GEOFENCE_TERMINATED, f"geofence breach ({violation}): motors terminated")
            return
        if action == "hold":
            self._failsafe_to(_Loiter(), f"geofence breach ({violation}): holding")
        elif action == "rtl":
            self._failsafe_to(_Rtl(5.0, math.inf), f"geofence breach ({violation}): returned to launch and landed")
        elif action == "land":
            self._sp = None  # land where the vehicle is, not at the setpoint ahead of it
            self._failsafe_to(_Land(0.7, math.inf), f"geofence breach ({violation}): landed")
