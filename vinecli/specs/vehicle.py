"""Vehicle specification (``vehicles/*.yaml``), validated with pydantic.

Frames: positions are metres in the body FLU frame, origin at the frame's centre of mass.
Units are in every field name or description. A file may start with ``base: other.yaml``
and override a few fields (PX4 airframe style).
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, model_validator

from vinecli.constants import STANDARD_GRAVITY
from vinecli.names import SafeName
from vinecli.specs import StrictModel
from vinecli.specs.limits import MAX_IMAGE_PX, MAX_RATE_HZ
from vinecli.specs.sprayer import SprayerSpec

Vec3L = tuple[float, float, float]

#: the vehicle of a world (and of ``vinecli plan rows`` on a DSM) that names none
DEFAULT_VEHICLE = "x500-sprayer"


class FrameSpec(StrictModel):
    """Rigid airframe without liquid, payload or rotors' own mass."""

    mass_kg: float = Field(gt=0, description="frame mass incl. empty tank, kg")
    inertia_kgm2: Vec3L = Field(description="principal inertia (ixx, iyy, izz) about the CoM, kg m², body FLU")
    collision_box_m: Vec3L = Field((0.35, 0.35, 0.12), description="collision box size (x, y, z), m")
    landing_gear_height_m: float = Field(0.10, ge=0, description="height of the CoM above the skids, m")


class MotorSpec(StrictModel):
    """Motor/propeller constants shared by every rotor (docs/flight-models.md §1)."""

    k_f: float = Field(gt=0, description="thrust constant, N/(rad/s)²")
    k_m: float = Field(ge=0, description="reaction torque / thrust, m")
    k_d: float = Field(0.0, ge=0, description="rotor drag (H-force) coefficient, N/(rad/s)/(m/s)")
    k_roll: float = Field(0.0, ge=0, description="rolling-moment coefficient, N m/(rad/s)/(m/s)")
    w_max: float = Field(gt=0, description="maximum rotor speed, rad/s")
    w_min_armed: float = Field(0.0, ge=0, description="rotor speed at zero throttle while armed, rad/s")
    tau_up_s: float = Field(gt=0, description="first-order time constant when spinning up, s")
    tau_down_s: float = Field(gt=0, description="first-order time constant when spinning down, s")
    rotor_mass_kg: float = Field(0.005, ge=0, description="mass of one rotor link, kg")
    prop_diameter_m: float = Field(0.254, gt=0, le=3.0, description="propeller diameter (disk area for momentum theory), m")

    def disk_area_m2(self) -> float:
        """One rotor's disk area pi D² / 4, m²."""
        return math.pi * self.prop_diameter_m**2 / 4.0


class RotorSpec(StrictModel):
    """One rotor: where it is and which way it spins (order = PX4 motor order)."""

    position_m: Vec3L = Field(description="rotor hub position, m, body FLU")
    spin: Literal["ccw", "cw"] = Field(description="direction seen from above; ccw -> s=+1 (reaction torque yaws CW)")
    axis: Vec3L = Field((0.0, 0.0, 1.0), description="thrust axis, unit vector, body FLU")

    @property
    def s(self) -> float:
        """+1 for CCW, -1 for CW."""
        return 1.0 if self.spin == "ccw" else -1.0


class DragLinkSpec(StrictModel):
    """Quadratic wind drag of one link: c = ½ ρ S C_D0 (given directly or as area + C_D0)."""

    coefficient_kg_per_m: float | None = Field(None, ge=0, description="c in F = c |V_app|², kg/m")
    area_m2: float | None = Field(None, ge=0, description="reference area S, m²")
    cd0: float | None = Field(None, ge=0, description="zero-lift drag coefficient C_D0")
    position_m: Vec3L = Field((0.0, 0.0, 0.0), description="centre of pressure, m, body FLU")

    @model_validator(mode="after")
    def _one_form(self) -> DragLinkSpec:
        direct = self.coefficient_kg_per_m is not None
        area = self.area_m2 is not None and self.cd0 is not None
        if direct == area:
            raise ValueError("give either coefficient_kg_per_m or both area_m2 and cd0")
        return self

    def coefficient(self, air_density: float) -> float:
        """c in kg/m for the given air density (kg/m³)."""
        if self.coefficient_kg_per_m is not None:
            return self.coefficient_kg_per_m
        return 0.5 * air_density * float(self.area_m2) * float(self.cd0)  # type: ignore[arg-type]


class TankSpec(StrictModel):
    """Spray tank (thesis 'sloshing-effects' plugin); the empty tank's mass is in the frame."""

    capacity_l: float = Field(gt=0, description="capacity, litres")
    liquid_density_kgm3: float = Field(1000.0, gt=0, description="liquid density, kg/m³")
    mount_m: Vec3L = Field((0.0, 0.0, -0.05), description="tank centre, m, body FLU")
    nozzle_max_flow_lps: float = Field(gt=0, description="maximum nozzle flow, litres/s")
    slosh: bool = Field(False, description="add the pendulum sloshing model (beyond the thesis)")
    slosh_damping_ratio: float = Field(0.05, ge=0, description="pendulum damping ratio")
    tank_height_m: float = Field(0.12, gt=0, description="inner height (pendulum length scale), m")


class BatterySpec(StrictModel):
    """Lithium-polymer pack and the electrical loads on it (vinecli/flight/battery.py).

    Open-circuit voltage per cell from the state of charge (energy fraction) by Chen &
    Rincón-Mora (2006) unless ``ocv_table`` gives ``[[soc, volts], ...]``; terminal voltage sags by
    ``I R`` with ``R = cells r_cell``. Failsafe thresholds as PX4's BAT_LOW_THR / BAT_CRIT_THR /
    BAT_EMERGEN_THR (state of charge, 0..1).
    """

    cells: int = Field(ge=1, le=24, description="cells in series (S)")
    capacity_wh: float = Field(gt=0, le=1e5, description="energy at full charge, Wh")
    internal_resistance_ohm_per_cell: float = Field(0.005, ge=0, le=1.0, description="Ω per cell")
    ocv_table: list[tuple[float, float]] | None = Field(None, description="[[soc 0..1, V per cell], ...] ascending in soc")
    initial_soc: float = Field(1.0, gt=0, le=1.0, description="state of charge at the start of a run")
    motor_efficiency: float = Field(0.80, gt=0, le=1.0, description="motor + ESC efficiency, shaft / electrical power")
    avionics_w: float = Field(10.0, ge=0, description="flight controller, GNSS, radios, W")
    pump_w_at_max_flow: float = Field(0.0, ge=0, description="spray pump power at the nozzle's maximum flow, W (linear in flow)")
    low_soc: float = Field(0.15, ge=0, lt=1, description="BAT_LOW_THR: warning / return for a refill")
    critical_soc: float = Field(0.07, ge=0, lt=1, description="BAT_CRIT_THR: return to launch")
    emergency_soc: float = Field(0.05, ge=0, lt=1, description="BAT_EMERGEN_THR: land now")

    @model_validator(mode="after")
    def _order(self) -> BatterySpec:
        if not self.emergency_soc <= self.critical_soc <= self.low_soc:
            raise ValueError("need emergency_soc <= critical_soc <= low_soc")
        if self.ocv_table is not None:
            socs = [p[0] for p in self.ocv_table]
            if len(socs) < 2 or socs != sorted(socs) or socs[0] > 0.0 or socs[-1] < 1.0:
                raise ValueError("ocv_table needs >= 2 points, ascending soc, covering 0..1")
        return self


class PayloadSpec(StrictModel):
    """Fixed extra mass (e.g. a camera or an overload)."""

    mass_kg: float = Field(0.0, ge=0, description="kg")
    position_m: Vec3L = Field((0.0, 0.0, -0.05), description="m, body FLU")


class MountSpec(StrictModel):
    """Sensor mounting pose relative to the body frame."""

    position_m: Vec3L = Field((0.0, 0.0, 0.0), description="m, body FLU")
    rpy_deg: Vec3L = Field((0.0, 0.0, 0.0), description="roll, pitch, yaw of the sensor frame, deg")


class ImuSpec(StrictModel):
    rate_hz: float = Field(250.0, gt=0, le=MAX_RATE_HZ)
    accel_noise_density: float = Field(0.002, ge=0, description="m/s²/√Hz")
    gyro_noise_density: float = Field(0.0002, ge=0, description="rad/s/√Hz")
    accel_bias_random_walk: float = Field(3e-4, ge=0, description="m/s³/√Hz")
    gyro_bias_random_walk: float = Field(4e-6, ge=0, description="rad/s²/√Hz")
    accel_quantization: float = Field(0.0, ge=0, description="m/s² per LSB (0 = none)")
    gyro_quantization: float = Field(0.0, ge=0, description="rad/s per LSB (0 = none)")
    mount: MountSpec = MountSpec()


class BaroSpec(StrictModel):
    rate_hz: float = Field(50.0, gt=0, le=MAX_RATE_HZ)
    noise_pa: float = Field(1.0, ge=0, description="white noise σ, Pa")
    drift_pa_per_sqrt_s: float = Field(0.0, ge=0, description="random-walk drift, Pa/√s")
    quantization_pa: float = Field(0.0, ge=0)


class MagSpec(StrictModel):
    rate_hz: float = Field(100.0, gt=0, le=MAX_RATE_HZ)
    noise_gauss: float = Field(0.0005, ge=0, description="white noise σ, gauss")
    mount: MountSpec = MountSpec()


class GnssSpec(StrictModel):
    rate_hz: float = Field(10.0, gt=0, le=MAX_RATE_HZ)
    horizontal_noise_m: float = Field(0.3, ge=0, description="σ per horizontal axis, m")
    vertical_noise_m: float = Field(0.5, ge=0, description="σ, m")
    velocity_noise_mps: float = Field(0.05, ge=0, description="σ per axis, m/s")
    satellites: int = Field(12, ge=0)
    mount: MountSpec = MountSpec()


class DepthCameraSpec(StrictModel):
    enabled: bool = False
    rate_hz: float = Field(5.0, gt=0, le=MAX_RATE_HZ)
    width_px: int = Field(64, gt=0, le=MAX_IMAGE_PX)
    height_px: int = Field(48, gt=0, le=MAX_IMAGE_PX)
    fov_deg: float = Field(70.0, gt=0, lt=180, description="vertical field of view")
    near_m: float = Field(0.1, gt=0)
    far_m: float = Field(30.0, gt=0)
    depth_noise_m: float = Field(0.0, ge=0)
    mount: MountSpec = MountSpec(position_m=(0.15, 0.0, -0.05), rpy_deg=(0.0, 60.0, 0.0))


class RangefinderSpec(StrictModel):
    """Distance sensor (PX4 ``distance_sensor``: lidar or radar altimeter). It measures along its mount
    frame's -z axis (down-facing with the default mount), from the mount position, to the terrain."""

    rate_hz: float = Field(20.0, gt=0, le=MAX_RATE_HZ)
    noise_m: float = Field(0.02, ge=0, description="white noise σ, m")
    min_range_m: float = Field(0.1, ge=0, description="closer than this: no valid reading, m")
    max_range_m: float = Field(12.0, gt=0, description="farther than this: no valid reading, m")
    mount: MountSpec = MountSpec()

    @model_validator(mode="after")
    def _ranges(self) -> RangefinderSpec:
        if self.max_range_m <= self.min_range_m:
            raise ValueError(f"max_range_m {self.max_range_m:g} must exceed min_range_m {self.min_range_m:g}")
        return self


class SensorsSpec(StrictModel):
    imu: ImuSpec = ImuSpec()
    baro: BaroSpec = BaroSpec()
    mag: MagSpec = MagSpec()
    gnss: GnssSpec = GnssSpec()
    depth_camera: DepthCameraSpec = DepthCameraSpec()
    rangefinder: RangefinderSpec | None = Field(None, description="downward distance sensor; none: the autopilot "
                                                "knows the terrain from the world's terrain database only")


class ControlSpec(StrictModel):
    """Built-in autopilot gains (PX4 multicopter controller structure and defaults)."""

    pos_p_xy: float = Field(0.95, ge=0, description="MPC_XY_P, 1/s")
    pos_p_z: float = Field(1.0, ge=0, description="MPC_Z_P, 1/s")
    vel_p_xy: float = Field(1.8, ge=0, description="MPC_XY_VEL_P_ACC, m/s² per m/s")
    vel_i_xy: float = Field(1.0, ge=0, description="MPC_XY_VEL_I_ACC (PX4 0.4; 1.0 rejects steady wind faster)")
    vel_d_xy: float = Field(0.2, ge=0, description="MPC_XY_VEL_D_ACC")
    vel_p_z: float = Field(4.0, ge=0, description="MPC_Z_VEL_P_ACC")
    vel_i_z: float = Field(2.0, ge=0, description="MPC_Z_VEL_I_ACC")
    vel_d_z: float = Field(0.0, ge=0, description="MPC_Z_VEL_D_ACC")
    att_p: Vec3L = Field((6.5, 6.5, 2.8), description="MC_ROLL_P, MC_PITCH_P, MC_YAW_P, 1/s")
    rate_p: Vec3L = Field((0.15, 0.15, 0.8), description="MC_*RATE_P (normalised torque per rad/s)")
    rate_i: Vec3L = Field((0.2, 0.2, 0.2), description="MC_*RATE_I")
    rate_d: Vec3L = Field((0.003, 0.003, 0.0), description="MC_*RATE_D")
    max_tilt_deg: float = Field(35.0, gt=0, lt=90, description="MPC_TILTMAX_AIR")
    max_vel_xy: float = Field(5.0, gt=0, description="MPC_XY_VEL_MAX, m/s")
    max_vel_up: float = Field(3.0, gt=0, description="MPC_Z_VEL_MAX_UP, m/s")
    max_vel_down: float = Field(1.5, gt=0, description="MPC_Z_VEL_MAX_DN, m/s")
    max_acc_xy: float = Field(5.0, gt=0, description="m/s²")
    lost_control_tilt_deg: float = Field(70.0, gt=0, le=180, description="tilt beyond which the run ends 'lost control'")
    preflight_max_tilt_deg: float = Field(30.0, gt=0, le=180,
                                          description="arming refused when tilted more than this at rest, deg")
    preflight_timeout_s: float = Field(10.0, gt=0, le=600,
                                       description="arming refused when the estimator has not converged by then, s")
    # --- added for the built-in autopilot (vinecli/control/cascade.py); normalised torque 1.0 =
    # sum|r_y| T_max / 2 about x (sum|r_x| T_max / 2 about y, n k_m T_max / 2 about z), see allocation.py
    yaw_weight: float = Field(0.4, ge=0, le=1, description="MC_YAW_WEIGHT: yaw share of the full attitude error")
    max_rate_deg_s: Vec3L = Field((220.0, 220.0, 200.0), description="MC_ROLLRATE_MAX, MC_PITCHRATE_MAX, MC_YAWRATE_MAX")
    rate_i_limit: float = Field(0.3, ge=0, description="MC_RR_INT_LIM: rate integrator limit, normalised torque")
    rate_d_cutoff_hz: float = Field(30.0, gt=0, description="IMU_DGYRO_CUTOFF: derivative low-pass, Hz")
    vel_d_cutoff_hz: float = Field(5.0, gt=0, description="velocity-derivative low-pass, Hz")
    vel_i_limit: float = Field(4.0, ge=0, description="horizontal velocity integrator limit, m/s² (vertical: g, as PX4)")
    thrust_min_frac: float = Field(0.12, ge=0, lt=1, description="MPC_THR_MIN: minimum collective thrust / max thrust")
    thrust_max_frac: float = Field(1.0, gt=0, le=1, description="MPC_THR_MAX: maximum collective thrust / max thrust")
    pos_loop_rate_hz: float = Field(50.0, gt=0, description="rate of the position/velocity loop, Hz (attitude/rate: every step)")
    max_yaw_rate_auto_deg_s: float = Field(45.0, gt=0, description="MPC_YAWRAUTO_MAX: yaw setpoint slew in auto modes")
    cannot_takeoff_s: float = Field(2.0, gt=0, description="time at full thrust without climbing before 'cannot take off', s")
    hover_thrust_range: float = Field(0.2, gt=0, le=0.4, description="HTE_THR_RANGE: the hover thrust estimate stays within "
                                      "this of the nominal (empty + payload) hover thrust, normalised thrust")
    hover_thrust_noise: float = Field(0.0036, ge=0.0001, le=1.0, description="HTE_HT_NOISE: how fast the hover thrust may "
                                      "change, normalised thrust/s (a sprayer: at least the full pump's drain rate)")


class Px4MappingSpec(StrictModel):
    """How PX4 actuator outputs u in [0, 1] map to rotor speed: w = w_min + u (w_max - w_min)."""

    motor_channels: list[int] | None = Field(None, description="output channel (0-based) driving each rotor, in rotor order")
    w_min_rad_s: float = Field(100.0, ge=0, description="rotor speed at u = 0 while armed (Gazebo: 100), rad/s")
    sprayer_channel: int = Field(8, ge=0, le=15, description="output channel of the sprayer pump (DO_SET_ACTUATOR set 1)")
    airframe: str = Field("none_iris", description="PX4_SIM_MODEL to start PX4 with")
    params: dict[str, int | float] = Field(default_factory=dict, description="PX4 parameters of this airframe: at boot when "
                                           "vinecli starts PX4 (--px4-bin), and over MAVLink before each mission "
                                           "(integers as INT32, others as REAL32)")


class FitProvenance(StrictModel):
    """Where a fitted vehicle came from (``vinecli vehicle fit``) and how far its replay of that log was from
    the flight; runs flown with it carry this into summary.json and the report."""

    log: str = Field(description="flight log file name")
    log_sha256: str = Field("", description="sha256 of the log's bytes")
    format: str = Field(description="ulog | dataflash")
    firmware: str = Field("", description="firmware and version the log names")
    hardware: str = Field("", description="flight controller the log names")
    flight_date_utc: str | None = Field(None, description="UTC time of the flight (GNSS), ISO 8601")
    fitted_utc: str = Field(description="when the fit ran, ISO 8601")
    vinecli_version: str = ""
    base: str = Field(description="the vehicle the unidentified parameters come from")
    mass_source: str = Field("", description="where the mass came from (a log gives forces per unit mass only)")
    fixed_from_base: list[str] = Field(default_factory=list, description="parameters the log could not identify")
    replay: dict[str, float | None] = Field(default_factory=dict, description="errors of this vehicle replaying the "
                                            "log: accel_rms_mps2, velocity_rms_mps, voltage_rms_v, energy_error_fraction")
    replay_baselines: dict[str, dict[str, float | None]] = Field(default_factory=dict,
                                                                 description="the same errors of the baselines")


class VehicleSpec(StrictModel):
    """A multicopter: frame, rotors, drag, tank, payload, sensors and controller gains."""

    name: SafeName
    description: str = ""
    frame: FrameSpec
    motor: MotorSpec
    rotors: list[RotorSpec] = Field(min_length=3)
    drag: dict[str, DragLinkSpec] = Field(default_factory=dict, description="per-link wind drag; 'base' is the frame")
    tank: TankSpec | None = None
    battery: BatterySpec | None = Field(None, description="pack and electrical loads; none = no energy model")

    sprayer: SprayerSpec = Field(default_factory=SprayerSpec, description="nozzles and droplets (used with a tank)")
    payload: PayloadSpec = PayloadSpec()
    sensors: SensorsSpec = SensorsSpec()
    control: ControlSpec = ControlSpec()
    px4: Px4MappingSpec = Px4MappingSpec()
    provenance: FitProvenance | None = Field(None, description="set by `vinecli vehicle fit`: the log it was fitted to")

    @property
    def n_rotors(self) -> int:
        return len(self.rotors)

    def dry_mass(self) -> float:
        """Frame + rotors + payload, kg (no liquid)."""
        return self.frame.mass_kg + self.n_rotors * self.motor.rotor_mass_kg + self.payload.mass_kg

    def liquid_mass(self, fill_l: float) -> float:
        """Liquid mass for a fill in litres, kg."""
        return 0.0 if self.tank is None else fill_l * 1e-3 * self.tank.liquid_density_kgm3

    def max_thrust(self) -> float:
        """Total thrust at w_max along the rotor axes, N."""
        return self.n_rotors * self.motor.k_f * self.motor.w_max**2

    def hover_speed(self, total_mass: float, g: float = STANDARD_GRAVITY) -> float:
        """Steady hover rotor speed sqrt(m g / (n k_f)), rad/s."""
        return math.sqrt(total_mass * g / (self.n_rotors * self.motor.k_f))
