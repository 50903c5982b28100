"""Pure-Python 6-DoF test double for closed-loop autopilot tests without PyBullet.

A rigid body (diagonal inertia) driven by the real :class:`vinecli.flight.motor.MotorBank`
(lag, thrust, reaction torque, rotor drag) and sampled by the real simulated sensors
(:func:`vinecli.flight.sensors.make_sensors`), integrated with semi-implicit Euler at the
vehicle's physics rate (250 Hz). Flat ground at z = 0; the base rests at
z = landing_gear_height. Ground contact: while on the ground and the net vertical force
does not lift the body, it stays put (level, at rest). World ENU, body FLU, SI units.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from vinecli.autopilot.base import AutopilotContext
from vinecli.autopilot.terrain import TerrainDatabase
from vinecli.flight.motor import MotorBank
from vinecli.flight.rangefinder import make_rangefinder
from vinecli.flight.sensors import make_sensors
from vinecli.frames import Vec3, quat_from_euler, quat_rotate, quat_to_euler, tilt_angle
from vinecli.geo import GeoOrigin
from vinecli.sim.perfect_estimator import PerfectEstimator
from vinecli.specs.mission import MissionSpec
from vinecli.specs.vehicle import VehicleSpec
from vinecli.types import Observation, RigidState

G = 9.80665
ORIGIN = GeoOrigin(45.0, 8.0, 200.0)


@dataclass
class Trace:
    t: list[float] = field(default_factory=list)
    pos: list[Vec3] = field(default_factory=list)
    vel: list[Vec3] = field(default_factory=list)
    rpy: list[Vec3] = field(default_factory=list)
    w_cmd: list[tuple[float, ...]] = field(default_factory=list)
    sp: list[Vec3] = field(default_factory=list)
    mode: list[str] = field(default_factory=list)
    flow: list[float] = field(default_factory=list)
    on_ground: list[bool] = field(default_factory=list)


class RigidBodyDouble:
    """One vehicle on flat ground; :meth:`fly` runs an autopilot against it."""

    def __init__(self, vehicle: VehicleSpec, *, liquid_l: float | None = None, seed: int = 1, rate_hz: float = 250.0,
                 yaw0: float = 0.0) -> None:
        self.vehicle = vehicle
        self.dt_us = int(round(1e6 / rate_hz))
        self.dt = self.dt_us * 1e-6
        self.liquid_l = (vehicle.tank.capacity_l if vehicle.tank else 0.0) if liquid_l is None else liquid_l
        self.extra_mass = 0.0  # kg added by a test (unknown to the autopilot)
        self.inertia = vehicle.frame.inertia_kgm2
        self.motors = MotorBank(vehicle.motor, vehicle.rotors)
        self.sensors = make_sensors(vehicle.sensors, ORIGIN, seed)
        self.rangefinder = make_rangefinder(vehicle.sensors.rangefinder, self.ground_height, 0.0, seed)
        self.z_rest = vehicle.frame.landing_gear_height_m
        self.pos = [0.0, 0.0, self.z_rest]
        self.vel = [0.0, 0.0, 0.0]
        self.quat = quat_from_euler(0.0, 0.0, yaw0)
        self.omega = [0.0, 0.0, 0.0]
        self.acc = (0.0, 0.0, 0.0)
        self.on_ground = True
        self.t_us = 0
        self.flow_cmd = 0.0
        #: extra world force (N, ENU) and body torque (N m, FLU) as functions of time (s)
        self.ext_force: Callable[[float], Vec3] | None = None
        self.ext_torque: Callable[[float], Vec3] | None = None

    @property
    def mass(self) -> float:
        """Total mass: dry + liquid + extra, kg."""
        return self.vehicle.dry_mass() + self.vehicle.liquid_mass(self.liquid_l) + self.extra_mass

    @mass.setter
    def mass(self, value: float) -> None:
        self.extra_mass += value - self.mass

    def context(self, mission: MissionSpec, **kw: object) -> AutopilotContext:
        """Autopilot context for this double (home = the resting base position; flat ground at z = 0 as
        the map; the simulator's perfect estimator when the mission flies on ground truth)."""
        kw.setdefault("terrain", TerrainDatabase(None, 0.0))
        if mission.truth:
            kw.setdefault("estimator", PerfectEstimator())
        return AutopilotContext(mission=mission, vehicle=self.vehicle, origin=ORIGIN,
                                home_enu=(0.0, 0.0, self.z_rest), physics_dt_us=self.dt_us, **kw)  # type: ignore[arg-type]

    def truth(self) -> RigidState:
        return RigidState(self.t_us, (self.pos[0], self.pos[1], self.pos[2]), self.quat,
                          (self.vel[0], self.vel[1], self.vel[2]), (self.omega[0], self.omega[1], self.omega[2]),
                          self.acc, self.on_ground)

    def observe(self) -> Observation:
        tr = self.truth()
        imu, baro, mag, gnss = self.sensors.sample_all(tr)
        rf = self.rangefinder.sample(self.t_us, tr.pos, tr.quat) if self.rangefinder is not None else None
        return Observation(self.t_us, tr, imu, baro, mag, gnss, rf, self.liquid_l)

    @staticmethod
    def ground_height(x: float, y: float) -> float:
        """The flat ground, z = 0 (ENU m)."""
        return 0.0

    def advance(self, w_cmd: tuple[float, ...], flow_lps: float = 0.0) -> None:
        """One physics step with the given rotor speed commands."""
        dt = self.dt
        t = self.t_us * 1e-6
        self.motors.update(w_cmd, dt)
        v_app = self.motors.apparent_air_body(self.quat, tuple(self.vel), tuple(self.omega), (0.0, 0.0, 0.0))
        f_b, tau = self.motors.wrench(v_app)
        if self.vehicle.tank is not None and flow_lps > 0.0:
            self.liquid_l = max(0.0, self.liquid_l - min(flow_lps, self.vehicle.tank.nozzle_max_flow_lps) * dt)
        m = self.mass
        fx, fy, fz = quat_rotate(self.quat, f_b)
        fz -= m * G
        if self.ext_force is not None:
            ex = self.ext_force(t)
            fx, fy, fz = fx + ex[0], fy + ex[1], fz + ex[2]
        tx, ty, tz = tau
        if self.ext_torque is not None:
            et = self.ext_torque(t)
            tx, ty, tz = tx + et[0], ty + et[1], tz + et[2]
        ax, ay, az = fx / m, fy / m, fz / m
        if self.on_ground and az <= 0.0:
            # resting on the ground: level, at rest (yaw kept)
            self.acc = (0.0, 0.0, 0.0)
            self.vel = [0.0, 0.0, 0.0]
            self.omega = [0.0, 0.0, 0.0]
            self.pos[2] = self.z_rest
            self.quat = quat_from_euler(0.0, 0.0, quat_to_euler(self.quat)[2])
        else:
            self.on_ground = False
            v0 = self.vel
            self.vel = [v0[0] + ax * dt, v0[1] + ay * dt, v0[2] + az * dt]
            self.acc = (ax, ay, az)
            self.pos = [self.pos[i] + self.vel[i] * dt for i in range(3)]
            ix, iy, iz = self.inertia
            wx, wy, wz = self.omega
            # Euler's equations
            dwx = (tx - (iz - iy) * wy * wz) / ix
            dwy = (ty - (ix - iz) * wz * wx) / iy
            dwz = (tz - (iy - ix) * wx * wy) / iz
            wx, wy, wz = wx + dwx * dt, wy + dwy * dt, wz + dwz * dt
            self.omega = [wx, wy, wz]
            x, y, z, w = self.quat
            h = 0.5 * dt
            nx = x + h * (w * wx + y * wz - z * wy)
            ny = y + h * (w * wy - x * wz + z * wx)
            nz = z + h * (w * wz + x * wy - y * wx)
            nw = w - h * (x * wx + y * wy + z * wz)
            n = math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
            self.quat = (nx / n, ny / n, nz / n, nw / n)
            if self.pos[2] <= self.z_rest and self.vel[2] <= 0.0:
                self.pos[2] = self.z_rest
                self.on_ground = True
                self.vel = [0.0, 0.0, 0.0]
                self.omega = [0.0, 0.0, 0.0]
                self.quat = quat_from_euler(0.0, 0.0, quat_to_euler(self.quat)[2])
        self.t_us += self.dt_us

    def fly(self, ap: object, seconds: float, *, on_step: Callable[[RigidBodyDouble], None] | None = None,
            trace_every: int = 5) -> Trace:
        """Run ``ap`` (reset already) for up to ``seconds`` or until its status is done."""
        tr = Trace()
        n = int(round(seconds / self.dt))
        for k in range(n):
            if on_step is not None:
                on_step(self)
            obs = self.observe()
            cmd = ap.step(obs)  # type: ignore[attr-defined]
            st = ap.status()  # type: ignore[attr-defined]
            if k % trace_every == 0:
                tr.t.append(self.t_us * 1e-6)
                tr.pos.append(tuple(self.pos))  # type: ignore[arg-type]
                tr.vel.append(tuple(self.vel))  # type: ignore[arg-type]
                tr.rpy.append(quat_to_euler(self.quat))
                tr.w_cmd.append(cmd.rotor_speed_cmd)
                tr.sp.append((st.extra.get("sp_x", math.nan), st.extra.get("sp_y", math.nan), st.extra.get("sp_z", math.nan)))
                tr.mode.append(st.mode)
                tr.flow.append(cmd.spray_flow_lps)
                tr.on_ground.append(self.on_ground)
            if st.done:
                break
            self.advance(cmd.rotor_speed_cmd, cmd.spray_flow_lps)
        return tr

    def tilt(self) -> float:
        return tilt_angle(self.quat)
