"""Data passed between the simulation loop, the sensors and the autopilot backends.

World frame ENU, body frame FLU, SI units, quaternions (x, y, z, w) body -> world,
integer-microsecond time stamps. These are plain slotted dataclasses (no numpy) because
they are created every physics step. Those made every step write their ``__init__`` out
(``init=False``): compiled, a dataclass's generated ``__init__`` is interpreted Python (~1 µs
per object), a written one is native.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from vinecli.frames import QuatXYZW, Vec3


@dataclass(slots=True, init=False)
class RigidState:
    """Ground-truth state of the vehicle's base (centre of mass)."""

    t_us: int
    pos: Vec3  # m, world ENU
    quat: QuatXYZW  # body FLU -> world ENU
    vel: Vec3  # m/s, world ENU
    omega_body: Vec3  # rad/s, body FLU
    acc: Vec3 = (0.0, 0.0, 0.0)  # m/s², world ENU (finite difference of vel over the step)
    on_ground: bool = True  # touching the terrain

    def __init__(self, t_us: int, pos: Vec3, quat: QuatXYZW, vel: Vec3, omega_body: Vec3,
                 acc: Vec3 = (0.0, 0.0, 0.0), on_ground: bool = True) -> None:
        self.t_us = t_us
        self.pos = pos
        self.quat = quat
        self.vel = vel
        self.omega_body = omega_body
        self.acc = acc
        self.on_ground = on_ground


@dataclass(slots=True, init=False)
class ImuSample:
    t_us: int
    accel_flu: Vec3  # specific force, m/s², body FLU (level at rest: (0, 0, +9.81))
    gyro_flu: Vec3  # rad/s, body FLU

    def __init__(self, t_us: int, accel_flu: Vec3, gyro_flu: Vec3) -> None:
        self.t_us = t_us
        self.accel_flu = accel_flu
        self.gyro_flu = gyro_flu


@dataclass(slots=True, init=False)
class BaroSample:
    t_us: int
    pressure_pa: float
    temperature_c: float
    altitude_m: float  # pressure altitude, m AMSL

    def __init__(self, t_us: int, pressure_pa: float, temperature_c: float, altitude_m: float) -> None:
        self.t_us = t_us
        self.pressure_pa = pressure_pa
        self.temperature_c = temperature_c
        self.altitude_m = altitude_m


@dataclass(slots=True, init=False)
class MagSample:
    t_us: int
    field_flu_gauss: Vec3  # body FLU, gauss

    def __init__(self, t_us: int, field_flu_gauss: Vec3) -> None:
        self.t_us = t_us
        self.field_flu_gauss = field_flu_gauss


@dataclass(slots=True, init=False)
class GnssSample:
    t_us: int
    lat_deg: float
    lon_deg: float
    alt_m: float  # AMSL
    vel_enu: Vec3  # m/s
    fix_type: int = 3
    satellites: int = 12
    eph_m: float = 0.3
    epv_m: float = 0.5

    # parameters: the dataclass's fields, written out (mypyc compiles a written __init__, not a generated one)
    def __init__(self, t_us: int, lat_deg: float, lon_deg: float, alt_m: float, vel_enu: Vec3, fix_type: int = 3,
                 satellites: int = 12, eph_m: float = 0.3, epv_m: float = 0.5) -> None:
        self.t_us = t_us
        self.lat_deg = lat_deg
        self.lon_deg = lon_deg
        self.alt_m = alt_m
        self.vel_enu = vel_enu
        self.fix_type = fix_type
        self.satellites = satellites
        self.eph_m = eph_m
        self.epv_m = epv_m


@dataclass(slots=True, init=False)
class RangeSample:
    """A distance sensor reading (PX4 ``distance_sensor``)."""

    t_us: int
    distance_m: float  # along the sensor axis, m (NaN when ``valid`` is False)
    valid: bool = True  # False: no return within the sensor's range

    def __init__(self, t_us: int, distance_m: float, valid: bool = True) -> None:
        self.t_us = t_us
        self.distance_m = distance_m
        self.valid = valid


@dataclass(slots=True, init=False)
class Observation:
    """What an autopilot sees at one physics step: sensor samples (None when a sensor has no
    new sample this step), the tank level and battery gauges, plus ground truth for the
    simulator-side parts (the perfect estimator of ``--truth`` runs, HIL_STATE_QUATERNION of the
    firmware bridges); the built-in autopilot never reads ``truth``."""

    t_us: int
    truth: RigidState
    imu: ImuSample
    baro: BaroSample | None = None
    mag: MagSample | None = None
    gnss: GnssSample | None = None
    rangefinder: RangeSample | None = None  # the rangefinder's reading (None: no new one, or no rangefinder)
    tank_level_l: float = 0.0
    battery_soc: float = math.nan  # state of charge 0..1 (NaN: the vehicle has no battery model)
    battery_voltage_v: float = math.nan  # terminal voltage under the last step's load, V
    battery_current_a: float = math.nan  # pack current over the last step, A (a firmware's current sensor)

    # parameters: the dataclass's fields, written out (mypyc compiles a written __init__, not a generated one)
    def __init__(self, t_us: int, truth: RigidState, imu: ImuSample, baro: BaroSample | None = None,
                 mag: MagSample | None = None, gnss: GnssSample | None = None, rangefinder: RangeSample | None = None,
                 tank_level_l: float = 0.0, battery_soc: float = math.nan, battery_voltage_v: float = math.nan,
                 battery_current_a: float = math.nan) -> None:
        self.t_us = t_us
        self.truth = truth
        self.imu = imu
        self.baro = baro
        self.mag = mag
        self.gnss = gnss
        self.rangefinder = rangefinder
        self.tank_level_l = tank_level_l
        self.battery_soc = battery_soc
        self.battery_voltage_v = battery_voltage_v
        self.battery_current_a = battery_current_a


@dataclass(frozen=True, slots=True)
class ServiceRequest:
    """What the ground crew does for a landed, disarmed vehicle (refill sorties)."""

    fill_l: float  # tank level after the refill, L
    swap_battery: bool  # a fresh battery at its initial state of charge


@dataclass(slots=True, init=False)
class ActuatorCommand:
    """Autopilot output for one step."""

    rotor_speed_cmd: tuple[float, ...]  # rad/s per rotor, vehicle rotor order
    spray_flow_lps: float = 0.0  # commanded nozzle flow, L/s
    armed: bool = False
    service: ServiceRequest | None = None  # ground crew request (only honoured on the ground, disarmed)

    def __init__(self, rotor_speed_cmd: tuple[float, ...], spray_flow_lps: float = 0.0, armed: bool = False,
                 service: ServiceRequest | None = None) -> None:
        self.rotor_speed_cmd = rotor_speed_cmd
        self.spray_flow_lps = spray_flow_lps
        self.armed = armed
        self.service = service


@dataclass(slots=True)
class Event:
    """Something that happened during a run (mode change, lift-off, geofence, tank empty...)."""

    t_us: int
    kind: str  # e.g. "mode", "liftoff", "touchdown", "geofence", "tank_empty", "phase", "status"
    message: str = ""
    data: dict[str, object] = field(default_factory=dict)
