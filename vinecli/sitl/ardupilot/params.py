"""ArduCopter parameters of a run, from the vehicle, the world and the mission.

* **Frame and motors**: FRAME_CLASS / FRAME_TYPE from the rotor layout (quad X, hexa X: the vinecli
  rotor order is ArduPilot's motor order, checked against ArduPilot's motor angles and spins); each
  rotor's servo output (``SERVOn_FUNCTION`` 33 + motor index); PWM 1000-2000 µs; the thrust curve
  MOT_THST_EXPO fitted to vinecli's motor (rotor speed linear in the output from ``w_min_armed`` to
  ``w_max``, thrust ~ w²); MOT_THST_HOVER from the take-off mass.
* **Loop**: SCHED_LOOP_RATE = the physics rate (one servo frame per physics step is one main loop).
  ArduPilot's SITL IMU then delivers one sample per loop, so its "gyro rate >= 1.8 x loop rate"
  pre-arm check (a guard against a misconfigured flight controller) cannot pass at any loop rate:
  ARMING_CHECK enables every check but the INS group.
* **Battery**: BATT_MONITOR 4 (analog voltage and current) reading the pack vinecli simulates (the
  backend sets SIM_BATT_VOLTAGE and the current sensor's offset every 0.1 s of simulated time, as
  ArduPilot 4.7's JSON backend has no battery field), BATT_CAPACITY, the capacity failsafes at the
  vehicle's critical (RTL) and emergency (land) state of charge, voltage compensation of the motors.
* **Sprayer** (AC_Sprayer, :func:`sprayer_params`).
* **Mission settings**: climb, cruise and landing speeds, waypoint radius, RTL altitude, fence.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from vinecli.errors import SpecError
from vinecli.specs.mission import GotoPhase, LandPhase, MissionSpec, RtlPhase, TakeoffPhase, WaypointsPhase
from vinecli.specs.sprayer import SprayerSpec
from vinecli.specs.vehicle import VehicleSpec

#: ARMING_CHECK bits: 1 all, 2 baro, 4 compass, 8 GPS lock, 16 INS, 32 parameters, 64 RC, 128 board
#: voltage, 256 battery, 512 airspeed, 1024 logging, 2048 safety switch, 4096 GPS config, 8192 system,
#: 16384 mission, 32768 rangefinder, 65536 camera, 131072 aux auth, 262144 visual odometry, 524288 FFT
ARMING_ALL_BUT_INS = (1 << 20) - 2 - 16
#: motor angles (deg clockwise from the nose, seen from above) and spins of ArduPilot's X frames,
#: in motor order (AP_MotorsMatrix): FRAME_CLASS 1 quad, 2 hexa; FRAME_TYPE 1 = X
AP_FRAMES: dict[int, tuple[int, tuple[tuple[float, str], ...]]] = {
    4: (1, ((45.0, "ccw"), (-135.0, "ccw"), (-45.0, "cw"), (135.0, "cw"))),
    6: (2, ((90.0, "cw"), (-90.0, "ccw"), (-30.0, "cw"), (150.0, "ccw"), (30.0, "ccw"), (-150.0, "cw"))),
}
MOTOR_FUNCTION_BASE = 33  # SERVOn_FUNCTION 33 = Motor1 ... 40 = Motor8
PUMP_FUNCTION = 22  # SprayerPump
SPINNER_FUNCTION = 23  # SprayerSpinner
PWM_MIN, PWM_MAX = 1000, 2000


def frame_for(vehicle: VehicleSpec) -> tuple[int, int]:
    """(FRAME_CLASS, FRAME_TYPE) for the vehicle's rotors; SpecError if they are not an ArduPilot X frame
    in ArduPilot's motor order (angle within 5°, same spin)."""
    n = vehicle.n_rotors
    if n not in AP_FRAMES:
        raise SpecError(f"vehicle {vehicle.name!r}: {n} rotors; the ArduPilot backend flies quad X and hexa X frames")
    frame_class, motors = AP_FRAMES[n]
    for i, (rotor, (angle, spin)) in enumerate(zip(vehicle.rotors, motors, strict=True)):
        x, y = float(rotor.position_m[0]), float(rotor.position_m[1])
        got = math.degrees(math.atan2(-y, x))  # FLU position -> clockwise angle from the nose
        off = abs((got - angle + 180.0) % 360.0 - 180.0)
        if off > 5.0 or rotor.spin != spin:
            raise SpecError(f"vehicle {vehicle.name!r}: rotor {i + 1} at {got:.0f} deg ({rotor.spin}) is not "
                            f"ArduPilot's motor {i + 1} of FRAME_CLASS {frame_class} X ({angle:.0f} deg, {spin}); "
                            "list the rotors in ArduPilot's motor order")
    return frame_class, 1


def thrust_expo(w_min: float, w_max: float) -> float:
    """MOT_THST_EXPO: least-squares fit of ArduPilot's thrust curve (1 - e) u + e u² to vinecli's
    motor, thrust (w/w_max)² with w = w_min + u (w_max - w_min), over the flying range u in [0.15, 1]."""
    a = w_min / w_max
    us = [0.15 + 0.85 * k / 100 for k in range(101)]
    num = den = 0.0
    for u in us:
        t = (a + (1.0 - a) * u) ** 2
        b = u * u - u
        num += (t - u) * b
        den += b * b
    return max(-1.0, min(1.0, num / den))


def hover_throttle(vehicle: VehicleSpec, mass_kg: float, g: float) -> float:
    """MOT_THST_HOVER: the thrust fraction that holds ``mass_kg`` (ArduPilot learns it in flight)."""
    return max(0.125, min(0.6875, mass_kg * g / vehicle.max_thrust()))


def vehicle_params(vehicle: VehicleSpec, *, physics_rate_hz: float, mass_kg: float, g: float,
                   motor_channels: Sequence[int] | None = None) -> dict[str, int | float]:
    """Frame, motors, loop rate, arming checks and battery (module docstring)."""
    fc, ft = frame_for(vehicle)
    m = vehicle.motor
    rate = int(round(physics_rate_hz))
    p: dict[str, int | float] = {
        "FRAME_CLASS": fc, "FRAME_TYPE": ft,
        "SCHED_LOOP_RATE": rate, "ARMING_CHECK": ARMING_ALL_BUT_INS,
        "MOT_PWM_MIN": PWM_MIN, "MOT_PWM_MAX": PWM_MAX,
        "MOT_THST_EXPO": round(thrust_expo(m.w_min_armed, m.w_max), 4),
        "MOT_THST_HOVER": round(hover_throttle(vehicle, mass_kg, g), 4),
        "AUTO_OPTIONS": 3,  # arm in AUTO, take off without raising the (absent) RC throttle
        "TERRAIN_ENABLE": 0,  # no terrain server: heights are planned by vinecli
    }
    for i, ch in enumerate(motor_channels or range(vehicle.n_rotors)):
        p[f"SERVO{ch + 1}_FUNCTION"] = MOTOR_FUNCTION_BASE + i
    b = vehicle.battery
    if b is not None:
        nominal_v = 3.7 * b.cells
        cap_mah = b.capacity_wh / nominal_v * 1000.0
        p.update({
            "BATT_MONITOR": 4, "BATT_VOLT_MULT": 10.1, "BATT_AMP_PERVLT": 1.0, "BATT_CAPACITY": int(round(cap_mah)),
            "BATT_LOW_MAH": int(round(b.critical_soc * cap_mah)), "BATT_CRT_MAH": int(round(b.emergency_soc * cap_mah)),
            "BATT_FS_LOW_ACT": 2, "BATT_FS_CRT_ACT": 1,  # RTL, land (the built-in autopilot's critical / emergency)
            "BATT_LOW_VOLT": 0.0, "BATT_CRT_VOLT": 0.0, "BATT_ARM_VOLT": 0.0,
            "MOT_BAT_VOLT_MAX": round(4.2 * b.cells, 2), "MOT_BAT_VOLT_MIN": round(3.3 * b.cells, 2),
        })
    return p


@dataclass(frozen=True)
class SprayerSetting:
    """What a mission asks of the pump: flow (L/s) at a ground speed (m/s)."""

    flow_lps: float
    speed_mps: float


def sprayer_params(setting: SprayerSetting, sprayer: SprayerSpec, *, pump_max_flow_lps: float, pump_channel: int,
                   spinner_channel: int | None = None) -> dict[str, int | float]:
    """AC_Sprayer from the vehicle's sprayer (``sprayer:``) and the mission's asked rate: the pump output follows
    ground speed, ``pump % = SPRAY_PUMP_RATE (% per m/s) x speed``, at least SPRAY_PUMP_MIN %, off below
    SPRAY_SPEED_MIN (cm/s). The pump output is a duty of the pump's maximum flow (``pump_max_flow_lps``, the
    maximum of vinecli's pump model, :meth:`vinecli.flight.pump.Pump.update_duty`), so the asked flow at the
    asked speed gives ``SPRAY_PUMP_RATE = 100 flow / (max flow x speed)`` and the litres per metre stay the asked
    ones at any speed above the minimum. SPRAY_SPEED_MIN is the sprayer's ``control.speed_min_mps`` (the built-in
    sprayer's switch-on speed) and SPRAY_PUMP_MIN the bottom of its flow range (the nozzles' minimum pressure,
    :meth:`~vinecli.specs.sprayer.SprayerSpec.flow_range_lps`; 0 without a pressure range). AC_Sprayer's on and off
    delays are compile-time (100 ms, 1000 ms), as the sprayer's default ``on_delay_s`` / ``off_delay_s``."""
    if setting.flow_lps <= 0.0 or setting.speed_mps <= 0.0:
        raise SpecError("ArduPilot's sprayer needs a spray flow and a speed above 0")
    lo, hi = sprayer.flow_range_lps(pump_max_flow_lps)
    if setting.flow_lps > hi * (1 + 1e-9):
        raise SpecError(f"the asked spray flow {setting.flow_lps:g} L/s is above the pump's maximum {hi:g} L/s")
    speed_min = sprayer.control.speed_min_mps
    if setting.speed_mps < speed_min:
        raise SpecError(f"the spray speed {setting.speed_mps:g} m/s is below the sprayer's minimum {speed_min:g} m/s "
                        "(sprayer.control.speed_min_mps, SPRAY_SPEED_MIN): AC_Sprayer would never switch on")
    p: dict[str, int | float] = {
        "SPRAY_ENABLE": 1,
        "SPRAY_PUMP_RATE": round(100.0 * setting.flow_lps / (pump_max_flow_lps * setting.speed_mps), 4),
        "SPRAY_SPEED_MIN": int(round(100.0 * speed_min)),
        "SPRAY_PUMP_MIN": round(100.0 * lo / pump_max_flow_lps, 2),
        f"SERVO{pump_channel + 1}_FUNCTION": PUMP_FUNCTION,
        f"SERVO{pump_channel + 1}_MIN": PWM_MIN, f"SERVO{pump_channel + 1}_MAX": PWM_MAX,
        f"SERVO{pump_channel + 1}_TRIM": PWM_MIN,
    }
    if spinner_channel is not None:
        p[f"SERVO{spinner_channel + 1}_FUNCTION"] = SPINNER_FUNCTION
    return p


def pump_fraction(pwm: int) -> float:
    """The pump output 0..1 of a servo PWM (µs) with SERVOn_MIN/MAX 1000/2000 (0 = no pulse)."""
    if pwm <= PWM_MIN:
        return 0.0
    return 1.0 if pwm >= PWM_MAX else (pwm - PWM_MIN) / (PWM_MAX - PWM_MIN)


#: GeofenceSpec.action -> FENCE_ACTION (ArduCopter: 0 report only, 1 RTL or land, 2 always land, 4 brake or land;
#: it has no motor cut-off, so "terminate" lands)
_FENCE_ACTION = {"none": 0, "warn": 0, "hold": 4, "rtl": 1, "land": 2, "terminate": 2}


def mission_settings(mission: MissionSpec) -> dict[str, int | float]:
    """ArduCopter parameters of ``mission``'s phases and geofence (the items are the converter's): the climb
    speed (WPNAV_SPEED_UP), the landing speed (LAND_SPEED, within ArduCopter's 30-200 cm/s, and LAND_SPEED_HIGH
    above LAND_ALT_LOW), the RTL altitude, the waypoint radius (the smallest acceptance radius, at least
    5 cm) and the fence (FENCE_ENABLE, FENCE_TYPE: 1 altitude, 2 circle, 4 polygon; FENCE_ACTION, ALT_MAX,
    RADIUS)."""
    p: dict[str, int | float] = {}
    radii = [0.5]
    for ph in mission.phases:
        if isinstance(ph, TakeoffPhase) and ph.climb_speed_mps is not None:
            p["WPNAV_SPEED_UP"] = round(100.0 * ph.climb_speed_mps, 1)
        elif isinstance(ph, LandPhase):
            p["LAND_SPEED"] = p["LAND_SPEED_HIGH"] = int(min(200, max(30, round(100.0 * ph.descent_speed_mps))))
        elif isinstance(ph, RtlPhase):
            p["RTL_ALT"] = int(round(100.0 * ph.return_altitude_agl_m))
        elif isinstance(ph, (GotoPhase, WaypointsPhase)):
            radii.append(ph.acceptance_radius_m)
    p["WPNAV_RADIUS"] = max(5, int(round(100.0 * min(radii))))
    gf = mission.geofence
    if gf is not None:
        kind = (1 if gf.max_altitude_agl_m is not None else 0) | (2 if gf.max_horizontal_distance_m is not None else 0) \
            | (4 if gf.polygon_enu else 0)
        if kind:
            p.update({"FENCE_ENABLE": 1, "FENCE_TYPE": kind, "FENCE_ACTION": _FENCE_ACTION[gf.action]})
        if gf.max_altitude_agl_m is not None:
            p["FENCE_ALT_MAX"] = float(gf.max_altitude_agl_m)
        if gf.max_horizontal_distance_m is not None:
            p["FENCE_RADIUS"] = float(gf.max_horizontal_distance_m)
    return p


__all__ = ["ARMING_ALL_BUT_INS", "SprayerSetting", "frame_for", "hover_throttle", "mission_settings",
           "pump_fraction", "sprayer_params", "thrust_expo", "vehicle_params"]
