"""The flight phases of the built-in autopilot: take-off, hold, loiter, path following (goto,
waypoints), sprayer switch, land, return to launch and open loop (the spray phase with its
refill sorties is in :mod:`vinecli.autopilot.phases.spray`).

Positions are world ENU m, speeds m/s, flows L/s, times s; altitudes of take-off and RTL are
above home (PX4 relative altitude).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from vinecli.autopilot.phases.phase import Phase, PhaseHost
from vinecli.control.path import PathFollower
from vinecli.errors import InputError
from vinecli.specs.mission import OpenLoopPhase, TakeoffPhase
from vinecli.specs.vehicle import VehicleSpec


class Takeoff(Phase):
    """Arm (after the preflight checks), spool up for ``spool_s``, then climb straight up to
    ``altitude_agl_m`` above home at the climb speed (m/s; default the vehicle's max_vel_up)."""

    MODE = "AUTO.TAKEOFF"
    type = "takeoff"

    def __init__(self, spec: TakeoffPhase, vehicle: VehicleSpec) -> None:
        self.spec = spec
        self.timeout_s = spec.timeout_s
        self.climb = spec.climb_speed_mps or vehicle.control.max_vel_up

    def start(self, ap: PhaseHost) -> None:
        self.target_z = ap.home[2] + self.spec.altitude_agl_m
        self.spool = 0.0
        if ap.armed:
            x, y, _ = ap.hold_sp()
        else:
            x, y = ap.pos[0], ap.pos[1]
        self.xy = (x, y)
        self.path: PathFollower | None = None

    def update(self, ap: PhaseHost, dt: float) -> bool:
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


class Hold(Phase):
    """Hold the last setpoint for ``duration_s`` s."""

    MODE = "AUTO.LOITER"
    type = "hold"

    def __init__(self, duration_s: float) -> None:
        self.duration = duration_s
        self.timeout_s = duration_s + 1.0

    def start(self, ap: PhaseHost) -> None:
        self.t = 0.0
        self.sp = ap.hold_sp()

    def update(self, ap: PhaseHost, dt: float) -> bool:
        self.t += dt
        ap.set_position(self.sp, (0.0, 0.0, 0.0))
        return self.t >= self.duration - 1e-9


class Loiter(Phase):
    """Hold forever (geofence 'hold' action)."""

    MODE = "AUTO.LOITER"
    type = "loiter"

    def start(self, ap: PhaseHost) -> None:
        # brake: hold the current position estimate
        self.sp = (ap.pos[0], ap.pos[1], ap.pos[2])

    def update(self, ap: PhaseHost, dt: float) -> bool:
        ap.set_position(self.sp, (0.0, 0.0, 0.0))
        return False


class FollowPath(Phase):
    """Goto / waypoints: follow a polyline of absolute ENU points (the follower is built by
    ``make`` when the phase starts, from where the vehicle is then); optional sprayer flow (L/s)
    and yaw (deg, ENU: 0 = east, counter-clockwise) set at the start."""

    MODE = "AUTO.MISSION"

    def __init__(self, type_: str, make: Callable[[PhaseHost], PathFollower], timeout_s: float,
                 flow: float | None = None, yaw_deg: float | None = None) -> None:
        self.type = type_
        self.make = make
        self.timeout_s = timeout_s
        self.flow = flow
        self.yaw_deg = yaw_deg

    def start(self, ap: PhaseHost) -> None:
        self.path = self.make(ap)
        if self.flow is not None:
            ap.set_flow(self.flow)
        if self.yaw_deg is not None:
            ap.cascade.set_yaw(math.radians(self.yaw_deg))

    def update(self, ap: PhaseHost, dt: float) -> bool:
        sp, vff, done = self.path.update(dt, ap.pos)
        ap.set_position(sp, vff, aff=self.path.aff)
        return done




class SetSprayerFlow(Phase):
    """Set the sprayer flow (L/s) and go on at once (no mode change)."""

    type = "sprayer"

    def __init__(self, flow: float) -> None:
        self.flow = flow
        self._mode = ""

    @property
    def mode(self) -> str:
        """The mode it started in (instantaneous, no mode change)."""
        return self._mode

    def start(self, ap: PhaseHost) -> None:
        self._mode = ap.mode
        ap.set_flow(self.flow)

    def update(self, ap: PhaseHost, dt: float) -> bool:
        if ap.armed:
            ap.set_position(ap.hold_sp(), (0.0, 0.0, 0.0))
        return True


class Land(Phase):
    """Descend at ``descent`` m/s holding x, y; disarm once the land detector says landed
    (:mod:`vinecli.autopilot.land_detector`: ground contact, then maybe landed, then landed)."""

    MODE = "AUTO.LAND"
    type = "land"

    def __init__(self, descent: float, timeout_s: float) -> None:
        self.descent = descent
        self.timeout_s = timeout_s

    def start(self, ap: PhaseHost) -> None:
        sp = ap.hold_sp()
        self.xy = (sp[0], sp[1])
        self.z = sp[2]

    def update(self, ap: PhaseHost, dt: float) -> bool:
        if not ap.armed:
            return True
        if ap.landed:
            ap.emit("land_detected", "touchdown detected", {"x": ap.pos[0], "y": ap.pos[1], "z": ap.pos[2]})
            ap.disarm()
            return True
        # velocity-controlled descent, position hold horizontally
        self.z -= self.descent * dt
        ap.set_position((self.xy[0], self.xy[1], self.z), (0.0, 0.0, -self.descent), z_velocity_only=True)
        return False


class Rtl(Phase):
    """Return to launch: climb to ``return_alt`` m above home (if lower), fly home at up to 5 m/s, then land."""

    MODE = "AUTO.RTL"
    type = "rtl"

    def __init__(self, return_alt: float, timeout_s: float, descent: float = 0.7) -> None:
        self.return_alt = return_alt
        self.timeout_s = timeout_s
        self.descent = descent

    def start(self, ap: PhaseHost) -> None:
        x, y, z = ap.hold_sp() if ap.armed else ap.pos
        h = ap.home
        zr = max(z, h[2] + self.return_alt)
        speed = min(5.0, ap.vehicle.control.max_vel_xy)
        pts = [(x, y, z), (x, y, zr), (h[0], h[1], zr)]
        c = ap.vehicle.control
        self.path = PathFollower(pts, speed, accel=2.0, acceptance_m=0.5, max_up=c.max_vel_up, max_down=c.max_vel_down)
        self.land: Land | None = None

    def update(self, ap: PhaseHost, dt: float) -> bool:
        if not ap.armed:
            return True
        if self.land is None:
            sp, vff, done = self.path.update(dt, ap.pos)
            ap.set_position(sp, vff, aff=self.path.aff)
            if done:
                self.land = Land(self.descent, math.inf)
                self.land.start(ap)
            return False
        return self.land.update(ap, dt)


class OpenLoop(Phase):
    """Rotor speeds (rad/s) from a schedule, no controller; the autopilot asks :meth:`command` each physics step."""

    MODE = "OPEN_LOOP"
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

    def start(self, ap: PhaseHost) -> None:
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

    def update(self, ap: PhaseHost, dt: float) -> bool:
        return False

