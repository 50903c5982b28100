"""The vehicle's physics models composed for one physics step (sim/runner.py module doc, step 4).

:meth:`VehiclePhysics.step` calls each law once, in this order, and sums what they push into ONE world
force at the centre of mass and ONE world torque (the loop's two PyBullet calls; equivalent to per-link
forces because the links are rigidly fixed):

1. motor lag (:meth:`MotorBank.update <vinecli.flight.motor.MotorBank.update>`) and the wind
   (:meth:`WindField.velocity <vinecli.flight.wind.WindField.velocity>`) at the CoM;
2. rotors: thrust, rotor drag, reaction torque and rolling moment from the air at each rotor
   (:meth:`MotorBank.wrench_com <vinecli.flight.motor.MotorBank.wrench_com>`, body FLU -> world);
3. link drag with its lever arm (:class:`~vinecli.flight.aero.BodyDrag`);
4. the pump delivers the commanded flow through its lag (:class:`~vinecli.flight.pump.Pump`), the tank
   drains what it delivers and the liquid pushes at its mount (:class:`~vinecli.flight.tank.Tank`,
   :class:`~vinecli.flight.tank.TankCoupling`);
5. the battery delivers the electrical load (:class:`~vinecli.flight.battery.ElectricalLoad`: shaft
   power / efficiency + avionics + pump) over the step (:class:`~vinecli.flight.battery.Battery`).
"""

from __future__ import annotations

import math
from typing import final

from vinecli.flight.aero import BodyDrag, apparent_velocity
from vinecli.flight.battery import Battery, ElectricalLoad
from vinecli.flight.motor import MotorBank
from vinecli.flight.pump import Pump
from vinecli.flight.tank import Tank, TankCoupling
from vinecli.flight.wind import WindField
from vinecli.frames import BodyFrame, Vec3
from vinecli.sim.row import Row
from vinecli.types import ActuatorCommand

__all__ = ["VehiclePhysics"]

@final
class VehiclePhysics:
    """Motors, wind, drag, tank and battery of one vehicle (module doc); after :meth:`step`, ``wind``
    (m/s ENU at the CoM), ``drag`` (N ENU), ``flow_cmd_lps`` and ``energy_j`` hold this step's values."""

    # parameters: one per physics law composed (each its own type, built once per run by sim.loop's
    # vehicle_physics)
    def __init__(self, motors: MotorBank, wind: WindField, drag: BodyDrag, tank: Tank | None,
                 coupling: TankCoupling | None, battery: Battery | None, load: ElectricalLoad | None,
                 rigid_mass_kg: float, pump: Pump | None = None) -> None:
        self.motors = motors
        self.wind_field = wind
        self.body_drag = drag
        self.tank = tank
        self.pump = pump
        self.coupling = coupling
        self.battery = battery
        self.load = load
        self.rigid_mass = rigid_mass_kg
        self.wind: Vec3 = (0.0, 0.0, 0.0)
        self.drag: Vec3 = (0.0, 0.0, 0.0)
        self.flow_cmd_lps = 0.0
        self.energy_j = 0.0  # drawn from the battery so far, J

    def mass_kg(self) -> float:
        """Rigid body + liquid, kg."""
        tank = self.tank
        return self.rigid_mass + (tank.mass_kg if tank is not None else 0.0)

    # parameters: called every physics step by the compiled loop with its state as plain floats and vectors:
    # an object to hold them would be built every step
    def step(self, frame: BodyFrame, t: float, pos: Vec3, vel: Vec3, omega: Vec3, omega_body: Vec3, acc: Vec3,
             alpha: Vec3, cmd: ActuatorCommand, dt: float) -> tuple[Vec3, Vec3]:
        """(force N, torque N m), world ENU about the CoM, for the step ``t`` -> ``t + dt`` of the body at
        ``pos``, attitude ``frame``, velocity ``vel``, rates ``omega`` (world) / ``omega_body`` (FLU), with
        finite-difference accelerations ``acc`` and ``alpha``, flying the command ``cmd`` (module doc)."""
        motors = self.motors
        motors.update(cmd.rotor_speed_cmd, dt)
        wind = self.wind_field.velocity(t, pos)
        self.wind = wind
        ax, ay, az = apparent_velocity(wind, vel)
        bx, by, bz = frame.to_body(ax, ay, az)  # the air at the CoM, body FLU
        obx, oby, obz = omega_body
        (fbx, fby, fbz), (tbx, tby, tbz) = motors.wrench_com(bx, by, bz, obx, oby, obz)
        fx, fy, fz = frame.to_world(fbx, fby, fbz)
        drag, (tx, ty, tz) = self.body_drag.wrench(frame, vel, omega, wind, frame.to_world(tbx, tby, tbz))
        self.drag = drag
        fx += drag[0]
        fy += drag[1]
        fz += drag[2]
        tank = self.tank
        flow = 0.0
        if tank is not None and self.coupling is not None:
            self.flow_cmd_lps = cmd.spray_flow_lps
            pump = self.pump
            tank.update(pump.update(self.flow_cmd_lps, dt) if pump is not None else self.flow_cmd_lps, dt)
            flow = tank.flow_lps
            (f0, f1, f2), (rx, ry, rz) = self.coupling.force(frame, acc, alpha, omega, (fx, fy, fz))
            fx += f0
            fy += f1
            fz += f2
            tx += ry * f2 - rz * f1
            ty += rz * f0 - rx * f2
            tz += rx * f1 - ry * f0
        battery = self.battery
        if battery is not None and self.load is not None:
            battery.update(self.load.power_w(motors.shaft_power, flow), dt)
            self.energy_j += battery.power_drawn_w * dt
        return (fx, fy, fz), (tx, ty, tz)

    def record(self, row: Row, cmd: ActuatorCommand, vel: Vec3) -> None:
        """This step's vehicle columns of a time-series row (sim/row.py): the rotors at the row's time, wind,
        drag, tank, mass and battery; ``vel`` the body's velocity, m/s ENU."""
        motors = self.motors
        row.rotor_w_radps = motors.w_start  # the speeds at the row's time
        row.rotor_cmd_radps = cmd.rotor_speed_cmd
        row.rotor_thrust_n = motors.thrust
        row.thrust_total_n = motors.thrust_total
        wx, wy, wz = self.wind
        row.wind_enu_x_mps, row.wind_enu_y_mps, row.wind_enu_z_mps = wx, wy, wz
        row.air_app_enu_x_mps, row.air_app_enu_y_mps, row.air_app_enu_z_mps = wx - vel[0], wy - vel[1], wz - vel[2]
        row.drag_enu_x_n, row.drag_enu_y_n, row.drag_enu_z_n = self.drag
        row.rotor_drag_flu_x_n, row.rotor_drag_flu_y_n, row.rotor_drag_flu_z_n = motors.rotor_drag_body
        tank = self.tank
        if tank is not None:
            row.tank_level_l, row.tank_mass_kg, row.tank_flow_lps = tank.level_l, tank.mass_kg, tank.flow_lps
            row.tank_flow_cmd_lps = self.flow_cmd_lps
            row.tank_force_enu_x_n, row.tank_force_enu_y_n, row.tank_force_enu_z_n = tank.force
            row.tank_force_grav_enu_z_n = tank.gravity_force[2]
            row.tank_force_inertial_enu_x_n, row.tank_force_inertial_enu_y_n, row.tank_force_inertial_enu_z_n = \
                tank.inertial_force
            row.total_mass_kg = self.rigid_mass + tank.mass_kg
        else:
            row.tank_level_l = row.tank_mass_kg = row.tank_flow_lps = row.tank_flow_cmd_lps = 0.0
            row.tank_force_enu_x_n = row.tank_force_enu_y_n = row.tank_force_enu_z_n = 0.0
            row.tank_force_grav_enu_z_n = 0.0
            row.tank_force_inertial_enu_x_n = row.tank_force_inertial_enu_y_n = row.tank_force_inertial_enu_z_n = 0.0
            row.total_mass_kg = self.rigid_mass
        b = self.battery  # state of charge at the row's time, voltage, current, power; NaN without one
        if b is not None:
            row.battery_soc, row.battery_voltage_v, row.battery_current_a = b.soc_start, b.voltage_v, b.current_a
            row.power_elec_w = b.power_drawn_w
        else:
            row.battery_soc = row.battery_voltage_v = row.battery_current_a = row.power_elec_w = math.nan
