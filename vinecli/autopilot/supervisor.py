"""The built-in autopilot's flight supervisor: mode, phase sequence, arming, preflight, failsafes
(geofence, battery, cannot take off) and the run status - everything a phase may ask of the
autopilot (:class:`~vinecli.autopilot.phases.phase.PhaseHost`). :class:`FlightSupervisor` is the base of
:class:`~vinecli.autopilot.builtin.BuiltinAutopilot`, which builds the state in ``reset`` and
runs the estimator and the controllers. World ENU, SI units.

Modes (PX4 names, in :attr:`AutopilotStatus.mode`): ``DISARMED``, ``AUTO.TAKEOFF``,
``AUTO.LOITER`` (hold, geofence hold), ``AUTO.MISSION`` (goto, waypoints, spray),
``AUTO.LAND``, ``AUTO.RTL``, ``OPEN_LOOP``.

Events (``drain_events``): ``mode`` {mode, previous}, ``phase`` {index, type, event:
start|end}, ``arming`` {armed}, ``sprayer`` {flow_lps}, ``land_detected``, ``geofence``
{action, gf_action, violation, x, y, z}, ``status`` {status, detail}.

Safety: "cannot take off" when the collective thrust is saturated (or the rotor commands are
at >= 95 % of w_max) for ``control.cannot_takeoff_s`` while the vehicle has not climbed
0.5 m above where it armed; "lost control" when the tilt exceeds
``control.lost_control_tilt_deg`` (checked by the attitude loop of ``BuiltinAutopilot``). Both end the run with that
status and disarm.
Geofence breach actions follow PX4 ``GF_ACTION``: none/warn (event only), hold (loiter
where the breach happened until the run's time limit), rtl / land (then the run ends
``failsafe`` with the breach in the detail: the mission was not flown to its end), terminate (motors off, status
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
from collections.abc import Callable

from vinecli.autopilot.base import RUNNING, AutopilotContext, AutopilotStatus, RunStatus
from vinecli.autopilot.estimate import StateEstimate
from vinecli.autopilot.geofence import GF_ACTION, Geofence
from vinecli.autopilot.phases.flight import Land, Loiter, OpenLoop, Rtl
from vinecli.autopilot.phases.phase import Phase
from vinecli.autopilot.preflight import (
    PreflightFailure,
    check_plan,
    check_spawn_fence,
    check_tilt,
    fence_margins_m,
    plan_points,
)
from vinecli.control.cascade import Cascade
from vinecli.frames import QuatXYZW, Vec3, quat_to_euler, tilt_angle
from vinecli.rows.plan import plan_accel
from vinecli.specs.vehicle import VehicleSpec
from vinecli.types import Event, ServiceRequest

log = logging.getLogger(__name__)
_NAN = float("nan")


class FlightSupervisor:
    """Mode, phase sequence, arming, preflight and failsafes of the built-in autopilot (see the module
    docstring); the :class:`~vinecli.autopilot.phases.phase.PhaseHost` its phases run on. The state below is
    set by :meth:`BuiltinAutopilot.reset <vinecli.autopilot.builtin.BuiltinAutopilot.reset>`."""

    # the run
    vehicle: VehicleSpec
    home: Vec3  # ENU m
    terrain: Callable[[float, float], float]  # terrain z (ENU m) at (x, y)
    geofence: Geofence | None
    cascade: Cascade
    estimator: StateEstimate
    spool_s: float  # rotor spool-up before take-off, s
    phases: list[Phase]
    # estimated state (world ENU / body FLU, SI)
    t_us: int
    pos: Vec3
    vel: Vec3
    quat: QuatXYZW  # attitude body FLU -> world ENU
    est_ready: bool
    mass: float  # kg
    tank_level_l: float
    tank_empty: bool
    battery_soc: float  # 0..1, NaN: no battery model
    # flight state
    mode: str
    armed: bool
    idle: bool
    airborne: bool
    ground_contact: bool
    landed: bool
    flow: float  # sprayer flow command, L/s
    sprayer_inhibited: bool  # a failsafe switched the sprayer off until the next arming
    sortie: int
    _status: AutopilotStatus
    _events: list[Event]
    _plan_failures: list[PreflightFailure]
    _phase_i: int
    _phase: Phase | None
    _phase_t: float  # s in the current phase
    _failsafe: bool  # flying a failsafe action (the run ends when it is done)
    _failsafe_detail: str
    _failsafe_status: RunStatus
    _battery_level: int  # 0 ok, 1 critical (returning), 2 emergency (landing)
    _z_armed: float  # z where the vehicle armed, ENU m
    _sat_t: float  # s thrust-limited near the ground
    _sp: Vec3 | None  # position setpoint, ENU m
    _w_cmd: tuple[float, ...]  # last rotor speed command, rad/s
    _service: ServiceRequest | None

    # ------------------------------------------------------------------ preflight
    def _mission_preflight(self, ctx: AutopilotContext) -> list[PreflightFailure]:
        """Checks that depend only on the mission and the world (fence margins, plan over the terrain)."""
        v = ctx.vehicle
        margins = fence_margins_m(self.estimator.sigma_h_m, self.estimator.sigma_v_m)
        out: list[PreflightFailure] = []
        spawn = check_spawn_fence(ctx.geofence, self.home, margins[0])
        if spawn is not None:
            out.append(spawn)
        pts = plan_points(ctx.mission, self.home, ctx.vine_rows_enu, self.terrain, v.frame.landing_gear_height_m,
                          fence=ctx.geofence, accel_mps2=plan_accel(v), vehicle=v, terrain_bounds=ctx.terrain_bounds,
                          air_density=ctx.air_density_kgm3, no_spray=ctx.no_spray_enu)
        out += check_plan(pts, ctx.geofence, self.home, margins, ctx.terrain_bounds)
        return out

    def preflight_ok(self) -> bool:
        """PX4-style arming checks; True when the vehicle may arm now. False while the estimator
        settles; a failed check ends the run ``preflight_failed`` (event ``preflight``)."""
        if not self.est_ready:
            limit = self.vehicle.control.preflight_timeout_s
            if self.t_us * 1e-6 >= limit:
                reason = self.estimator.not_ready_reason
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
        """End the run ``preflight_failed`` (event ``preflight`` {check, value, limit})."""
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

    # ------------------------------------------------------------------ commands from the phases (PhaseHost)
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
        """Disarm: motors off, sprayer off, no setpoint; mode ``DISARMED``."""
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
        """Sprayer flow command, L/s (held at 0 after a failsafe); event ``sprayer`` when it switches on or off."""
        if self.sprayer_inhibited:
            flow = 0.0
        if (flow > 0.0) != (self.flow > 0.0):
            self.emit("sprayer", f"sprayer flow {flow:g} L/s" if flow > 0.0 else "sprayer off", {"flow_lps": flow})
        self.flow = flow

    def abort(self, detail: str) -> None:
        """Abandon the mission (a job that cannot go on): sprayer off, return home and land, then end the run
        ``aborted`` with ``detail``; on the ground, end it at once."""
        self.set_flow(0.0)
        if not (self.armed and self.airborne):
            self.disarm()
            self._finish(RunStatus.ABORTED, detail)
            return
        self._failsafe_to(Rtl(5.0, math.inf), detail, RunStatus.ABORTED)

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

    # ------------------------------------------------------------------ mode, run status, phase sequence
    def _set_mode(self, mode: str) -> None:
        """Switch to PX4 mode ``mode`` (event ``mode`` when it changes)."""
        if mode != self.mode:
            self.emit("mode", mode, {"mode": mode, "previous": self.mode})
            self.mode = mode
            self._status.mode = mode

    def _finish(self, status: RunStatus, detail: str) -> None:
        """End the run with ``status`` (the first call wins; motors off for the fatal ones), event ``status``."""
        st = self._status
        if st.status is not RUNNING:
            return
        if self.armed and status in (RunStatus.CANNOT_TAKE_OFF, RunStatus.LOST_CONTROL, RunStatus.GEOFENCE_TERMINATED):
            self.disarm()  # motors off; a completed or timed-out run just ends where it is
        st.status = status
        st.detail = detail
        self.emit("status", f"{status.value}: {detail}", {"status": status.value, "detail": detail})
        log.info("run ends: %s (%s)", status.value, detail)

    def _next_phase(self) -> None:
        """Start the next phase of :attr:`phases`; after the last the run ends ``completed``."""
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
        self._set_mode(ph.mode if (self.armed or isinstance(ph, OpenLoop)) else self.mode)

    def _end_phase(self) -> None:
        """The current phase is done: the next one, or - for a failsafe action - the run ends ``completed``."""
        ph = self._phase
        if ph is None:
            return
        if self._failsafe:
            self._phase = None
            self._finish(self._failsafe_status, self._failsafe_detail)
            return
        self.emit("phase", f"phase {self._phase_i} ({ph.type}) end", {"index": self._phase_i, "type": ph.type, "event": "end"})
        self._next_phase()

    def _failsafe_to(self, ph: Phase, detail: str, status: RunStatus = RunStatus.FAILSAFE) -> None:
        """Leave the mission for failsafe action ``ph``; when it is done the run ends ``status`` (``failsafe``: the
        mission was not flown to its end) with ``detail``."""
        self._failsafe = True
        self._failsafe_detail = detail
        self._failsafe_status = status
        self._phase = ph
        self._phase_t = 0.0
        ph.start(self)
        self._set_mode(ph.mode)

    def _advance_phase(self, dt: float) -> bool:
        """Run the current phase for ``dt`` s (position-loop rate): its timeout, its end, the next phase
        and the mode it flies in. False when the run ended."""
        ph = self._phase
        if ph is not None:
            self._phase_t += dt
            if self._phase_t > ph.timeout_s:
                self._finish(RunStatus.TIMEOUT, f"phase {self._phase_i} ({ph.type}) timed out after {ph.timeout_s:g} s")
                return False
            if ph.update(self, dt):
                self._end_phase()
                if self._status.status is not RUNNING:
                    return False
                if self._phase is not None and not isinstance(self._phase, OpenLoop):
                    self._phase.update(self, 0.0)
            if self.armed and self._phase is not None and self.mode != self._phase.mode:
                self._set_mode(self._phase.mode)
        return True

    # ------------------------------------------------------------------ safety checks (position-loop rate)
    def _safety_checks(self, dt: float) -> bool:
        """Cannot take off, geofence and battery, every ``dt`` s; False when a check ended the run."""
        v = self.vehicle
        h_agl = self.pos[2] - self._z_armed
        if self.armed and not isinstance(self._phase, OpenLoop) and not self.idle:
            c = self.cascade
            w_max = v.motor.w_max
            near_max = sum(self._w_cmd) >= 0.95 * w_max * len(self._w_cmd)
            if (c.thrust_saturated > 0 or near_max) and h_agl < 0.5 and self.vel[2] < 0.3:
                self._sat_t += dt
                if self._sat_t >= v.control.cannot_takeoff_s:
                    self._finish(RunStatus.CANNOT_TAKE_OFF,
                                 f"thrust-limited for {self._sat_t:.1f} s at {h_agl:.2f} m above the start "
                                 f"(max thrust {v.max_thrust():.1f} N)")
                    return False
            else:
                self._sat_t = 0.0
        if self.geofence is not None and self.armed and self.airborne:
            viol = self.geofence.check(self.pos)
            if viol and self._failsafe:
                log.debug("geofence breach (%s) during the failsafe: no new action", viol)
            elif viol:
                self._on_geofence(viol)
                if self._status.status is not RUNNING:
                    return False
        self._check_battery()
        return True

    def _check_battery(self) -> None:
        """PX4 BAT_CRIT_THR / BAT_EMERGEN_THR: return to launch at the critical state of charge, land
        where it is at the emergency one (each once per flight; a return or landing in progress goes on).
        Only armed and airborne, with a battery model (the vehicle has a battery and the state of charge is not NaN)."""
        b, soc = self.vehicle.battery, self.battery_soc
        if b is None or soc != soc or not (self.armed and self.airborne):
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
            self._failsafe_to(Land(0.7, math.inf), f"low battery ({detail}): landed")
        else:
            self.failsafe("low_battery", "rtl", detail)
            self._failsafe_to(Rtl(5.0, math.inf), f"low battery ({detail}): returned to launch and landed")

    def _on_geofence(self, violation: str) -> None:
        """A fence breach (``violation``: max_altitude, max_distance or polygon): event ``geofence``, then the GF_ACTION."""
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
            self._failsafe_to(Loiter(), f"geofence breach ({violation}): holding")
        elif action == "rtl":
            self._failsafe_to(Rtl(5.0, math.inf), f"geofence breach ({violation}): returned to launch and landed")
        elif action == "land":
            self._sp = None  # land where the vehicle is, not at the setpoint ahead of it
            self._failsafe_to(Land(0.7, math.inf), f"geofence breach ({violation}): landed")
