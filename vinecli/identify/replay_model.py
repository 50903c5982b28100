"""A vehicle driven by a log's motor outputs: vinecli's own laws on a rigid body, no PyBullet.

The forces and torques are the simulator's (:class:`~vinecli.flight.motor.MotorBank`: first-order motor
lag, thrust ``k_f w²``, rotor drag, rolling moment, reaction torque; :func:`~vinecli.flight.aero.wind_drag`
per drag link at its centre of pressure) on the vehicle's rigid mass and inertia
(:func:`~vinecli.vehicle.urdf.rigid_inertia`), integrated with PyBullet's scheme (semi-implicit Euler) at
the simulator's 250 Hz, in still air and without ground contact: a replay window is airborne. The forces
act at the log's attitude; the body rates are integrated open loop as a prediction (:meth:`VehicleReplay.step`). The motor
command of an output ``u`` is the PX4 SITL mapping ``w = w_min + u (w_max - w_min)`` (``px4.w_min_rad_s``,
``motor.w_max``); a stopped or disarmed motor is commanded 0. The electrical load is
:class:`~vinecli.flight.battery.ElectricalLoad` of the rotors' shaft power, drawn from a
:class:`~vinecli.flight.battery.Battery`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.flight.aero import wind_drag
from vinecli.flight.battery import Battery, ElectricalLoad
from vinecli.flight.motor import MotorBank
from vinecli.frames import QuatXYZW, Vec3, cross, quat_rotate, quat_rotate_inv
from vinecli.specs.vehicle import VehicleSpec
from vinecli.vehicle.urdf import rigid_inertia

__all__ = ["AIR_DENSITY", "RATE_HZ", "RigidState6", "VehicleReplay"]

RATE_HZ = 250.0
#: step of the pack's run over the whole flight, s (the motor lag is solved exactly at any step; the battery
#: samples come at 1-10 Hz)
BATTERY_DT = 0.02
#: ISA sea-level air density, kg/m³ (a log does not carry it)
AIR_DENSITY = 1.225


@dataclass
class RigidState6:
    """Position (m ENU), attitude (x, y, z, w body FLU -> ENU), velocity (m/s ENU), body rates (rad/s FLU; the
    model's open-loop prediction, see :meth:`VehicleReplay.step`)."""

    pos: Vec3
    quat: QuatXYZW
    vel: Vec3
    omega: Vec3


class VehicleReplay:
    """The vehicle's laws, one step at a time (module docstring)."""

    def __init__(self, vehicle: VehicleSpec, *, air_density: float = AIR_DENSITY, g: float = STANDARD_GRAVITY) -> None:
        self.vehicle = vehicle
        self.mass, _, inertia = rigid_inertia(vehicle)
        self.inertia: Vec3 = inertia
        self.g = g
        self.motors = MotorBank(vehicle.motor, list(vehicle.rotors))
        self.links = [(d.coefficient(air_density), tuple(float(c) for c in d.position_m)) for d in vehicle.drag.values()]
        self.w_min = float(vehicle.px4.w_min_rad_s)
        self.w_max = float(vehicle.motor.w_max)
        self.dt = 1.0 / RATE_HZ
        #: specific force of the last step, m/s² body FLU (what an IMU at the CoM reads)
        self.specific_force: Vec3 = (0.0, 0.0, 0.0)

    def commands(self, u: Sequence[float], running: bool) -> list[float]:
        """Rotor speed commands (rad/s) of outputs ``u`` (NaN: stopped)."""
        if not running:
            return [0.0] * len(u)
        span = self.w_max - self.w_min
        return [0.0 if math.isnan(x) else self.w_min + x * span for x in u]

    def step(self, s: RigidState6, w_cmd: Sequence[float], quat: QuatXYZW, omega: Vec3) -> RigidState6:
        """Advance ``s`` by one step with rotor commands ``w_cmd`` (held over the step) at the attitude ``quat``
        and body rates ``omega`` (rad/s FLU) the log measured.

        The translational state (position, velocity) integrates the model's forces; the rates in ``s`` integrate
        the model's torques open loop (Euler's equations) and are a prediction only: the attitude the forces
        act in is the log's (the 250-400 Hz attitude loop that keeps a real multicopter upright is not in a
        5-10 Hz log, so an open-loop attitude diverges within a second on the log's trim alone)."""
        dt, m = self.dt, self.mass
        self.motors.update(w_cmd, dt)
        vx, vy, vz = s.vel
        bx, by, bz = quat_rotate_inv(quat, (-vx, -vy, -vz))  # still air: apparent air = -v
        (fx, fy, fz), (tx, ty, tz) = self.motors.wrench_com(bx, by, bz, *omega)
        dx = dy = dz = 0.0
        omega_w = quat_rotate(quat, omega)
        for c, r_b in self.links:
            r_w = quat_rotate(quat, r_b)  # type: ignore[arg-type]
            vr = cross(omega_w, r_w)
            f = wind_drag(c, (-vx - vr[0], -vy - vr[1], -vz - vr[2]))
            dx, dy, dz = dx + f[0], dy + f[1], dz + f[2]
            tb = quat_rotate_inv(quat, cross(r_w, f))
            tx, ty, tz = tx + tb[0], ty + tb[1], tz + tb[2]
        db = quat_rotate_inv(quat, (dx, dy, dz))
        self.specific_force = ((fx + db[0]) / m, (fy + db[1]) / m, (fz + db[2]) / m)
        fw = quat_rotate(quat, (fx, fy, fz))
        ax, ay, az = (fw[0] + dx) / m, (fw[1] + dy) / m, (fw[2] + dz) / m - self.g
        ix, iy, iz = self.inertia
        wx, wy, wz = s.omega
        gx, gy, gz = cross((wx, wy, wz), (ix * wx, iy * wy, iz * wz))
        rates = (wx + (tx - gx) / ix * dt, wy + (ty - gy) / iy * dt, wz + (tz - gz) / iz * dt)
        vel = (vx + ax * dt, vy + ay * dt, vz + az * dt)
        pos = (s.pos[0] + vel[0] * dt, s.pos[1] + vel[1] * dt, s.pos[2] + vel[2] * dt)
        return RigidState6(pos, quat, vel, rates)

    def battery_run(self, t: np.ndarray, u: np.ndarray, running: np.ndarray, soc0: float,
                    t_out: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Motors (their own lag) and pack over the outputs ``u`` at times ``t`` (zero-order hold) from state of
        charge ``soc0``, in steps of :data:`BATTERY_DT`: (terminal voltage V at ``t_out``, load power W per step,
        step start times s)."""
        spec = self.vehicle.battery
        if spec is None:
            raise ValueError("the vehicle has no battery")
        bank = MotorBank(self.vehicle.motor, list(self.vehicle.rotors))
        pack = Battery(spec, soc0)
        load = ElectricalLoad(spec, None)  # no pump
        bank.reset(self.commands(u[0], bool(running[0])))
        dt = BATTERY_DT
        n_steps = int(math.floor((t[-1] - t[0]) / dt)) + 1
        ts = t[0] + dt * np.arange(n_steps)
        k = np.clip(np.searchsorted(t, ts, side="right") - 1, 0, len(t) - 1)
        volts = np.empty(n_steps)
        loads = np.empty(n_steps)
        cmds = [self.commands(row, bool(run)) for row, run in zip(u, running, strict=True)]
        for i in range(n_steps):
            bank.update(cmds[k[i]], dt)
            bank.wrench(None)
            pack.update(load.power_w(bank.shaft_power, 0.0), dt)
            volts[i] = pack.voltage_v
            loads[i] = pack.load_w
        return np.interp(t_out, ts, volts), loads, ts
