"""THE time-series row: a declared schema (:data:`COLUMNS`: each column's name, unit and source) and the row the
loop fills by name (:class:`Row`).

The columns, in the order ``timeseries.parquet`` keeps them, are :data:`COLUMNS` with the rotor columns
(:data:`ROTOR_COLUMNS`, rotors numbered 1..n) where :data:`ROTORS_AFTER` ends. A :class:`Row` has one field per
column, named as the column (the rotor columns: one sequence per rotor column, ``rotor_w_radps`` ...): the loop
(:meth:`Row.set_truth`, :meth:`Row.set_sensors`, :meth:`Row.set_ground`, :meth:`Row.set_autopilot`) and the
vehicle's physics (:meth:`vinecli.sim.vehicle_physics.VehiclePhysics.record`) set the fields by name;
:meth:`Row.values` lists them in the columns' order for the recorder (:class:`vinecli.sim.recorder.Recorder`, whose
columns are :func:`timeseries_columns`), and the Parquet writer (:func:`vinecli.runs.rundir.write_timeseries`)
keeps that order. A column's ``source`` is the value it records, a Python expression over what the loop holds at
the row's time (``t`` s, ``truth`` the RigidState, ``euler``/``tilt`` of its attitude, ``cmd`` the autopilot's
ActuatorCommand, ``status`` its AutopilotStatus, ``imu``, ``baro_alt``/``gnss`` the last fixes, ``terrain_z``,
``agl``, ``physics`` the VehiclePhysics and its ``motors``, ``tank``, ``battery``; ``i`` the rotor index from 0):
``tests/sim/test_row.py`` evaluates every source against the writers, so a value written to another column fails.
"""

from __future__ import annotations

import math
from typing import Final, NamedTuple, final

from vinecli.autopilot.base import AutopilotStatus
from vinecli.frames import quat_to_euler, tilt_angle
from vinecli.types import ImuSample, RigidState

__all__ = ["COLUMNS", "ROTORS_AFTER", "ROTOR_COLUMNS", "Column", "Row", "column_units", "timeseries_columns"]

NAN: Final = math.nan


class Column(NamedTuple):
    """One time-series column: its name (SI unit and frame in it), unit, and the value it records (module doc)."""

    name: str
    unit: str
    source: str


def _xyz(name: str, unit: str, source: str) -> list[Column]:
    """Three columns of a vector: ``name`` and ``source`` with ``{a}`` the axis (x, y, z) and ``{k}`` its index."""
    return [Column(name.format(a=a), unit, source.format(k=k)) for k, a in enumerate("xyz")]


#: the rotor columns of rotor ``i`` (0-based; named ``rotor{i + 1}_...``), between the body's and the vehicle's
ROTOR_COLUMNS: Final = (
    Column("rotor{n}_w_radps", "rad/s", "motors.w_start[i]"),
    Column("rotor{n}_cmd_radps", "rad/s", "cmd.rotor_speed_cmd[i]"),
    Column("rotor{n}_thrust_n", "N", "motors.thrust[i]"),
)
#: every other column, in order; the rotor columns follow the column named :data:`ROTORS_AFTER`
COLUMNS: Final = (
    Column("t_s", "s", "t"),
    *_xyz("pos_enu_{a}_m", "m", "truth.pos[{k}]"),
    *_xyz("vel_enu_{a}_mps", "m/s", "truth.vel[{k}]"),
    *_xyz("acc_enu_{a}_mps2", "m/s²", "truth.acc[{k}]"),
    *[Column(f"quat_{a}", "1", f"truth.quat[{k}]") for k, a in enumerate("xyzw")],
    Column("roll_rad", "rad", "euler[0]"),
    Column("pitch_rad", "rad", "euler[1]"),
    Column("yaw_rad", "rad", "euler[2]"),
    Column("tilt_rad", "rad", "tilt"),
    *_xyz("omega_flu_{a}_radps", "rad/s", "truth.omega_body[{k}]"),
    Column("thrust_total_n", "N", "motors.thrust_total"),
    *_xyz("wind_enu_{a}_mps", "m/s", "physics.wind[{k}]"),
    *_xyz("air_app_enu_{a}_mps", "m/s", "physics.wind[{k}] - truth.vel[{k}]"),
    *_xyz("drag_enu_{a}_n", "N", "physics.drag[{k}]"),
    *_xyz("rotor_drag_flu_{a}_n", "N", "motors.rotor_drag_body[{k}]"),
    Column("tank_level_l", "L", "tank.level_l if tank else 0.0"),
    Column("tank_mass_kg", "kg", "tank.mass_kg if tank else 0.0"),
    Column("tank_flow_lps", "L/s", "tank.flow_lps if tank else 0.0"),
    Column("tank_flow_cmd_lps", "L/s", "physics.flow_cmd_lps if tank else 0.0"),
    *_xyz("tank_force_enu_{a}_n", "N", "tank.force[{k}] if tank else 0.0"),
    Column("tank_force_grav_enu_z_n", "N", "tank.gravity_force[2] if tank else 0.0"),
    *_xyz("tank_force_inertial_enu_{a}_n", "N", "tank.inertial_force[{k}] if tank else 0.0"),
    Column("total_mass_kg", "kg", "physics.mass_kg()"),
    *_xyz("imu_accel_flu_{a}_mps2", "m/s²", "imu.accel_flu[{k}]"),
    *_xyz("imu_gyro_flu_{a}_radps", "rad/s", "imu.gyro_flu[{k}]"),
    Column("baro_alt_m", "m", "baro_alt"),
    Column("gnss_lat_deg", "deg", "gnss[0]"),
    Column("gnss_lon_deg", "deg", "gnss[1]"),
    Column("gnss_alt_m", "m", "gnss[2]"),
    Column("terrain_z_m", "m", "terrain_z"),
    Column("height_agl_m", "m", "agl"),
    Column("on_ground", "1", "1.0 if truth.on_ground else 0.0"),
    *[Column(f"sp_pos_enu_{a}_m", "m", f"status.extra.get('sp_{a}', nan)") for a in "xyz"],
    Column("phase_index", "1", "float(status.phase_index)"),
    Column("armed", "1", "1.0 if cmd.armed else 0.0"),
    Column("battery_soc", "1", "battery.soc_start if battery else nan"),
    Column("battery_voltage_v", "V", "battery.voltage_v if battery else nan"),
    Column("battery_current_a", "A", "battery.current_a if battery else nan"),
    Column("power_elec_w", "W", "battery.power_drawn_w if battery else nan"),
    Column("sortie", "1", "status.extra.get('sortie', nan)"),
)
ROTORS_AFTER: Final = "omega_flu_z_radps"


def timeseries_columns(n_rotors: int) -> list[str]:
    """Column names in recording order (rotors numbered 1..n)."""
    return [c.name for c in _columns(n_rotors)]


def column_units(n_rotors: int) -> dict[str, str]:
    """``{column: unit}`` in recording order."""
    return {c.name: c.unit for c in _columns(n_rotors)}


def _columns(n_rotors: int) -> list[Column]:
    names = [c.name for c in COLUMNS]
    k = names.index(ROTORS_AFTER) + 1
    rotors = [Column(c.name.format(n=i + 1), c.unit, c.source) for i in range(n_rotors) for c in ROTOR_COLUMNS]
    return [*COLUMNS[:k], *rotors, *COLUMNS[k:]]


@final
class Row:
    """One time-series row, by column (module doc): set its fields, then :meth:`values` in the columns' order."""

    def __init__(self, n_rotors: int) -> None:
        self.n_rotors = n_rotors
        self.t_s = NAN
        self.pos_enu_x_m = self.pos_enu_y_m = self.pos_enu_z_m = NAN
        self.vel_enu_x_mps = self.vel_enu_y_mps = self.vel_enu_z_mps = NAN
        self.acc_enu_x_mps2 = self.acc_enu_y_mps2 = self.acc_enu_z_mps2 = NAN
        self.quat_x = self.quat_y = self.quat_z = self.quat_w = NAN
        self.roll_rad = self.pitch_rad = self.yaw_rad = self.tilt_rad = NAN
        self.omega_flu_x_radps = self.omega_flu_y_radps = self.omega_flu_z_radps = NAN
        self.rotor_w_radps: tuple[float, ...] = (NAN,) * n_rotors
        self.rotor_cmd_radps: tuple[float, ...] = (NAN,) * n_rotors
        self.rotor_thrust_n: list[float] = [NAN] * n_rotors
        self.thrust_total_n = NAN
        self.wind_enu_x_mps = self.wind_enu_y_mps = self.wind_enu_z_mps = NAN
        self.air_app_enu_x_mps = self.air_app_enu_y_mps = self.air_app_enu_z_mps = NAN
        self.drag_enu_x_n = self.drag_enu_y_n = self.drag_enu_z_n = NAN
        self.rotor_drag_flu_x_n = self.rotor_drag_flu_y_n = self.rotor_drag_flu_z_n = NAN
        self.tank_level_l = self.tank_mass_kg = self.tank_flow_lps = self.tank_flow_cmd_lps = NAN
        self.tank_force_enu_x_n = self.tank_force_enu_y_n = self.tank_force_enu_z_n = NAN
        self.tank_force_grav_enu_z_n = NAN
        self.tank_force_inertial_enu_x_n = self.tank_force_inertial_enu_y_n = self.tank_force_inertial_enu_z_n = NAN
        self.total_mass_kg = NAN
        self.imu_accel_flu_x_mps2 = self.imu_accel_flu_y_mps2 = self.imu_accel_flu_z_mps2 = NAN
        self.imu_gyro_flu_x_radps = self.imu_gyro_flu_y_radps = self.imu_gyro_flu_z_radps = NAN
        self.baro_alt_m = self.gnss_lat_deg = self.gnss_lon_deg = self.gnss_alt_m = NAN
        self.terrain_z_m = self.height_agl_m = self.on_ground = NAN
        self.sp_pos_enu_x_m = self.sp_pos_enu_y_m = self.sp_pos_enu_z_m = NAN
        self.phase_index = self.armed = NAN
        self.battery_soc = self.battery_voltage_v = self.battery_current_a = self.power_elec_w = NAN
        self.sortie = NAN

    def set_truth(self, truth: RigidState) -> None:
        """The body's state at the row's time: time, position, velocity, acceleration, attitude, rates."""
        self.t_s = truth.t_us * 1e-6
        self.pos_enu_x_m, self.pos_enu_y_m, self.pos_enu_z_m = truth.pos
        self.vel_enu_x_mps, self.vel_enu_y_mps, self.vel_enu_z_mps = truth.vel
        self.acc_enu_x_mps2, self.acc_enu_y_mps2, self.acc_enu_z_mps2 = truth.acc
        quat = truth.quat
        self.quat_x, self.quat_y, self.quat_z, self.quat_w = quat
        self.roll_rad, self.pitch_rad, self.yaw_rad = quat_to_euler(quat)
        self.tilt_rad = tilt_angle(quat)
        self.omega_flu_x_radps, self.omega_flu_y_radps, self.omega_flu_z_radps = truth.omega_body

    def set_sensors(self, imu: ImuSample, baro_alt: float, gnss: tuple[float, float, float]) -> None:
        """What the sensors measured: this step's IMU sample, the last barometer and GNSS fixes."""
        self.imu_accel_flu_x_mps2, self.imu_accel_flu_y_mps2, self.imu_accel_flu_z_mps2 = imu.accel_flu
        self.imu_gyro_flu_x_radps, self.imu_gyro_flu_y_radps, self.imu_gyro_flu_z_radps = imu.gyro_flu
        self.baro_alt_m = baro_alt
        self.gnss_lat_deg, self.gnss_lon_deg, self.gnss_alt_m = gnss

    def set_ground(self, terrain_z: float, agl: float, on_ground: bool) -> None:
        """The terrain under the vehicle (m), the skids' height above it (m), contact with it."""
        self.terrain_z_m = terrain_z
        self.height_agl_m = agl
        self.on_ground = 1.0 if on_ground else 0.0

    def set_autopilot(self, status: AutopilotStatus, armed: bool) -> None:
        """What the autopilot reports: its set point, phase, sortie; whether it armed the motors."""
        ex = status.extra
        self.sp_pos_enu_x_m = ex.get("sp_x", NAN)
        self.sp_pos_enu_y_m = ex.get("sp_y", NAN)
        self.sp_pos_enu_z_m = ex.get("sp_z", NAN)
        self.phase_index = float(status.phase_index)
        self.armed = 1.0 if armed else 0.0
        self.sortie = ex.get("sortie", NAN)

    def values(self) -> list[float]:
        """The row's values in the columns' order (:func:`timeseries_columns`)."""
        v = [self.t_s, self.pos_enu_x_m, self.pos_enu_y_m, self.pos_enu_z_m,
             self.vel_enu_x_mps, self.vel_enu_y_mps, self.vel_enu_z_mps,
             self.acc_enu_x_mps2, self.acc_enu_y_mps2, self.acc_enu_z_mps2,
             self.quat_x, self.quat_y, self.quat_z, self.quat_w, self.roll_rad, self.pitch_rad, self.yaw_rad,
             self.tilt_rad, self.omega_flu_x_radps, self.omega_flu_y_radps, self.omega_flu_z_radps]
        w, cmd, thrust = self.rotor_w_radps, self.rotor_cmd_radps, self.rotor_thrust_n
        for i in range(self.n_rotors):
            v.append(w[i])
            v.append(cmd[i])
            v.append(thrust[i])
        v += [self.thrust_total_n, self.wind_enu_x_mps, self.wind_enu_y_mps, self.wind_enu_z_mps,
              self.air_app_enu_x_mps, self.air_app_enu_y_mps, self.air_app_enu_z_mps,
              self.drag_enu_x_n, self.drag_enu_y_n, self.drag_enu_z_n,
              self.rotor_drag_flu_x_n, self.rotor_drag_flu_y_n, self.rotor_drag_flu_z_n,
              self.tank_level_l, self.tank_mass_kg, self.tank_flow_lps, self.tank_flow_cmd_lps,
              self.tank_force_enu_x_n, self.tank_force_enu_y_n, self.tank_force_enu_z_n, self.tank_force_grav_enu_z_n,
              self.tank_force_inertial_enu_x_n, self.tank_force_inertial_enu_y_n, self.tank_force_inertial_enu_z_n,
              self.total_mass_kg,
              self.imu_accel_flu_x_mps2, self.imu_accel_flu_y_mps2, self.imu_accel_flu_z_mps2,
              self.imu_gyro_flu_x_radps, self.imu_gyro_flu_y_radps, self.imu_gyro_flu_z_radps,
              self.baro_alt_m, self.gnss_lat_deg, self.gnss_lon_deg, self.gnss_alt_m,
              self.terrain_z_m, self.height_agl_m, self.on_ground,
              self.sp_pos_enu_x_m, self.sp_pos_enu_y_m, self.sp_pos_enu_z_m, self.phase_index, self.armed,
              self.battery_soc, self.battery_voltage_v, self.battery_current_a, self.power_elec_w, self.sortie]
        return v
