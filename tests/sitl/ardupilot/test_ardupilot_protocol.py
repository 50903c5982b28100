"""ArduPilot's JSON SITL protocol and ArduCopter parameters, checked against ArduPilot's own arithmetic
(SIM_JSON.cpp's clock, Location::offset, AC_Sprayer::update) re-done here from the C++ sources."""

from __future__ import annotations

import json
import math
import struct

import pytest
from loopback_world import ORIGIN

from vinecli.errors import InputError, SpecError
from vinecli.sitl.ardupilot.json_link import parse_servo_frame, state_line, timestamp_s
from vinecli.sitl.ardupilot.mission_plan import LOCATION_SCALING_FACTOR_INV, ArdupilotFrame
from vinecli.sitl.ardupilot.params import (
    ARMING_ALL_BUT_INS,
    SprayerSetting,
    frame_for,
    pump_fraction,
    sprayer_params,
    thrust_expo,
    vehicle_params,
)
from vinecli.sitl.ardupilot.process import param_file_text
from vinecli.specs.sprayer import SprayerSpec
from vinecli.vehicle import load_vehicle


def test_servo_frames_16_and_32_channels_and_garbage():
    f = parse_servo_frame(struct.pack("<HHI16H", 18458, 250, 7, *range(1000, 1016)))
    assert f is not None and (f.rate_hz, f.count, f.pwm[0], f.pwm[15], len(f.pwm)) == (250, 7, 1000, 1015, 16)
    f32 = parse_servo_frame(struct.pack("<HHI32H", 29569, 400, 9, *([1500] * 32)))
    assert f32 is not None and len(f32.pwm) == 32
    assert parse_servo_frame(struct.pack("<HHI16H", 1234, 250, 7, *([1000] * 16))) is None
    assert parse_servo_frame(b"\x1a\x48\x00") is None
    assert parse_servo_frame(struct.pack("<HHI8H", 18458, 250, 7, *([1000] * 8))) is None  # short


def _ardupilot_clock(stamps: list[float]) -> list[int]:
    """SIM_JSON.cpp: ``time_now_us += (timestamp - last) * 1e6`` on a uint64 (truncated by the conversion)."""
    t, last, out = 0, 0.0, []
    for s in stamps:
        t = int(float(t) + (float(repr(s)) - last) * 1.0e6)  # the stamp goes through text (repr -> atof)
        last = float(repr(s))
        out.append(t)
    return out


@pytest.mark.parametrize("dt_us", [4000, 2500, 3333, 1000])
def test_time_stamps_keep_the_firmware_clock_on_the_physics_clock(dt_us):
    n = 50_000  # 200 s at 250 Hz (plain decimal stamps lose their first microsecond within 20 steps)
    clock = _ardupilot_clock([timestamp_s(k, dt_us) for k in range(1, n + 1)])
    assert clock == [k * dt_us for k in range(1, n + 1)]
    naive = _ardupilot_clock([k * dt_us / 1e6 for k in range(1, n + 1)])
    assert naive != clock  # plain decimal stamps lose microseconds (why the half microsecond is there)


def test_state_line_is_compact_json_ardupilot_can_parse():
    line = state_line(1.5, (0.1, -0.2, 0.3), (0.0, 0.0, -9.80665), (1.0, 2.0, -3.0), (0.5, 0.0, -0.1),
                      (1.0, 0.0, 0.0, 0.0))
    text = line.decode()
    assert text.startswith("\n") and text.endswith("\n") and ": " not in text and ", " not in text
    doc = json.loads(text)
    assert doc["imu"]["accel_body"] == [0.0, 0.0, -9.80665] and doc["quaternion"] == [1.0, 0.0, 0.0, 0.0]
    for key in ('"timestamp":', '"gyro":[', '"accel_body":[', '"position":[', '"velocity":[', '"quaternion":['):
        assert key in text  # ArduPilot skips exactly `"key":` before reading the value
    with pytest.raises(Exception, match="non-finite"):
        state_line(1.0, (math.nan, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))


def test_frames_from_the_rotor_layout():
    assert frame_for(load_vehicle("x500-sprayer")) == (1, 1)
    assert frame_for(load_vehicle("hex-sprayer")) == (2, 1)
    v = load_vehicle("x500-sprayer")
    swapped = v.model_copy(update={"rotors": [v.rotors[2], v.rotors[1], v.rotors[0], v.rotors[3]]})
    with pytest.raises(SpecError, match="rotor 1"):
        frame_for(swapped)


def test_thrust_curve_fit():
    assert thrust_expo(0.0, 1000.0) == pytest.approx(1.0)  # thrust ~ u² exactly
    e = thrust_expo(100.0, 1300.0)
    assert 0.75 < e < 0.95
    a = 100.0 / 1300.0  # the fitted curve stays within 3 % of full thrust of the motor's over the flying range
    worst = max(abs((1 - e) * u + e * u * u - (a + (1 - a) * u) ** 2) for u in [0.15 + 0.01 * k for k in range(86)])
    assert worst < 0.03


def test_vehicle_parameters():
    v = load_vehicle("x500-sprayer")
    p = vehicle_params(v, physics_rate_hz=250.0, mass_kg=3.32, g=9.80665)
    assert p["SCHED_LOOP_RATE"] == 250 and p["ARMING_CHECK"] == ARMING_ALL_BUT_INS and not p["ARMING_CHECK"] & 16
    assert [p[f"SERVO{i}_FUNCTION"] for i in range(1, 5)] == [33, 34, 35, 36]
    assert p["MOT_THST_HOVER"] == pytest.approx(3.32 * 9.80665 / v.max_thrust(), abs=1e-4)
    b = v.battery
    assert b is not None and p["BATT_CAPACITY"] == round(b.capacity_wh / (3.7 * b.cells) * 1000)
    assert p["BATT_LOW_MAH"] > p["BATT_CRT_MAH"] > 0


def _ac_sprayer_pump_pct(speed_mps: float, p: dict) -> float:
    """AC_Sprayer::update: pos = ground_speed(cm/s) x PUMP_RATE, at least 100 x PUMP_MIN, at most 10000."""
    if 100.0 * speed_mps < p["SPRAY_SPEED_MIN"]:
        return 0.0
    pos = min(10000.0, max(100.0 * speed_mps * p["SPRAY_PUMP_RATE"], 100.0 * p["SPRAY_PUMP_MIN"]))
    return pos / 100.0


def test_sprayer_parameters_give_the_asked_flow_per_metre():
    setting = SprayerSetting(flow_lps=0.0142, speed_mps=2.0)  # 20 L/ha on a 3.55 m swath at 2 m/s
    sprayer = SprayerSpec()  # switch-on speed 1 m/s, no pressure range
    p = sprayer_params(setting, sprayer, pump_max_flow_lps=0.1, pump_channel=8)
    assert p["SERVO9_FUNCTION"] == 22 and p["SPRAY_ENABLE"] == 1
    assert p["SPRAY_SPEED_MIN"] == 100 and p["SPRAY_PUMP_MIN"] == 0.0  # sprayer.control.speed_min_mps, no floor
    for v in (1.0, 2.0, 3.0):  # litres per metre stay the asked ones at any speed above the minimum
        pwm = 1000 + 10 * _ac_sprayer_pump_pct(v, p)
        flow = pump_fraction(round(pwm)) * 0.1
        assert flow / v == pytest.approx(0.0142 / 2.0, rel=0.01)
    assert _ac_sprayer_pump_pct(0.9, p) == 0.0  # below SPRAY_SPEED_MIN: off
    with pytest.raises(SpecError, match="above the pump"):
        sprayer_params(SprayerSetting(0.2, 2.0), sprayer, pump_max_flow_lps=0.1, pump_channel=8)
    with pytest.raises(SpecError, match="below the sprayer's minimum"):
        sprayer_params(SprayerSetting(0.005, 0.8), sprayer, pump_max_flow_lps=0.1, pump_channel=8)


def test_sprayer_parameters_come_from_the_vehicles_sprayer():
    """The ag-hexa-16's sprayer (pressure range, switch-on speed): SPRAY_PUMP_MIN is the nozzles' minimum flow as
    a share of the pump's maximum, SPRAY_SPEED_MIN its speed_min_mps; a flow above the nozzles' maximum pressure is
    refused; the pump output at the asked speed is the asked flow as the pump model's duty."""
    from vinecli.flight.pump import Pump
    v = load_vehicle("ag-hexa-16")
    assert v.tank is not None
    q_max = v.tank.nozzle_max_flow_lps
    lo, hi = v.sprayer.flow_range_lps(q_max)
    assert 0.0 < lo < hi <= q_max
    q = 0.5 * (lo + hi)
    p = sprayer_params(SprayerSetting(q, 5.0), v.sprayer, pump_max_flow_lps=q_max, pump_channel=8)
    assert p["SPRAY_PUMP_MIN"] == pytest.approx(100.0 * lo / q_max, abs=0.01)
    assert p["SPRAY_SPEED_MIN"] == round(100.0 * v.sprayer.control.speed_min_mps)
    duty = _ac_sprayer_pump_pct(5.0, p) / 100.0
    pump = Pump(v.sprayer.pump, q_max)
    for _ in range(2500):  # 10 s at 250 Hz: the pump model settles on the duty's flow
        pump.update_duty(duty, 0.004)
    assert pump.flow_lps == pytest.approx(q, rel=1e-3)
    assert _ac_sprayer_pump_pct(1.2, p) == pytest.approx(p["SPRAY_PUMP_MIN"])  # slow: held at the nozzles' minimum
    with pytest.raises(SpecError, match="above the pump"):
        sprayer_params(SprayerSetting(1.05 * hi, 5.0), v.sprayer, pump_max_flow_lps=q_max, pump_channel=8)


def test_waypoints_use_ardupilots_offset_not_wgs84():
    lat, lon, alt = ORIGIN.enu_to_geodetic(3.0, -4.0, 1.2)
    fr = ArdupilotFrame((3.0, -4.0, 1.2), round(lat * 1e7), round(lon * 1e7), alt)
    assert fr.offset_e7(3.0, -4.0) == (fr.lat_e7, fr.lng_e7)
    la, lo = fr.offset_e7(3.0, 96.0)  # 100 m north
    assert la - fr.lat_e7 == int(100.0 * LOCATION_SCALING_FACTOR_INV) and lo == fr.lng_e7
    # vinecli's WGS84 tangent plane puts the same point 15 cm further north at 46 deg: the two differ
    w_lat = ORIGIN.enu_to_geodetic_fast(3.0, 96.0, 0.0)[0]
    assert abs((round(w_lat * 1e7) - la) / LOCATION_SCALING_FACTOR_INV) > 0.1
    _, lo_e = fr.offset_e7(103.0, -4.0)  # 100 m east: scaled by cos(latitude)
    assert (lo_e - fr.lng_e7) == pytest.approx(100.0 * LOCATION_SCALING_FACTOR_INV / math.cos(math.radians(lat)), abs=1)


def test_parameter_file_format_and_validation():
    text = param_file_text({"FRAME_CLASS": 1, "MOT_THST_EXPO": 0.8123})
    assert "FRAME_CLASS 1\n" in text and "MOT_THST_EXPO 0.8123\n" in text
    with pytest.raises(InputError, match="parameter name"):
        param_file_text({"frame": 1})
    with pytest.raises(InputError, match="finite"):
        param_file_text({"FRAME_CLASS": math.inf})


def test_mission_settings_from_the_phases_and_the_fence():
    from vinecli.sitl.ardupilot.params import mission_settings
    from vinecli.specs.mission import MissionSpec

    m = MissionSpec.model_validate({
        "name": "m", "phases": [{"type": "takeoff", "altitude_agl_m": 5.0, "climb_speed_mps": 1.5},
                                {"type": "goto", "position_enu": [3.0, 4.0], "acceptance_radius_m": 0.3},
                                {"type": "rtl", "return_altitude_agl_m": 6.0}, {"type": "land", "descent_speed_mps": 0.1}],
        "geofence": {"polygon_enu": [[-10, -10], [10, -10], [10, 10]], "max_altitude_agl_m": 15.0, "action": "hold"}})
    p = mission_settings(m)
    assert p["WPNAV_SPEED_UP"] == 150.0 and p["RTL_ALT"] == 600 and p["WPNAV_RADIUS"] == 30
    assert p["LAND_SPEED"] == p["LAND_SPEED_HIGH"] == 30  # 10 cm/s asked, ArduCopter's minimum 30
    assert (p["FENCE_ENABLE"], p["FENCE_TYPE"], p["FENCE_ACTION"], p["FENCE_ALT_MAX"]) == (1, 5, 4, 15.0)
    assert "FENCE_RADIUS" not in p
