"""Derived metrics on synthetic time series with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vinecli.frames import quat_from_axis_angle
from vinecli.geometry import point_polyline_distance
from vinecli.missions.metrics import METRICS, dominant_period
from vinecli.missions.rundata import MetricContext, RunData

G = 9.80665


def m(name: str, data: RunData, window=None) -> float:
    return METRICS[name].fn(data, window)


def takeoff_series(force_scale: float = 1.0, drag_sign: float = 1.0) -> RunData:
    """On the ground until 2 s, 1 s of 2 m/s² acceleration, then a 2 m/s climb."""
    t = np.arange(0, 8.0, 0.02)
    acc = np.where((t >= 2.0) & (t < 3.0), 2.0, 0.0)
    vel = np.where(t < 2.0, 0.0, np.where(t < 3.0, 2.0 * (t - 2.0), 2.0))
    on_ground = (t < 2.0).astype(float)
    mass = np.full(t.shape, 1.0)
    fz = -mass * (G + acc) * force_scale
    drag = -drag_sign * 0.05 * vel * np.abs(vel)
    ts = {
        "t_s": t, "acc_enu_z_mps2": acc, "vel_enu_z_mps": vel, "on_ground": on_ground, "tank_mass_kg": mass,
        "tank_force_enu_z_n": fz, "tank_force_inertial_enu_z_n": -mass * acc, "drag_enu_z_n": drag,
        "pos_enu_z_m": 0.2 + np.concatenate([[0.0], np.cumsum(vel[:-1]) * 0.02]),
    }
    return RunData(ts, events=[(2.0, "liftoff")], context=MetricContext(gravity=G))


def test_takeoff_metrics() -> None:
    d = takeoff_series()
    assert m("tank_force_rest_ratio", d) == pytest.approx(1.0)
    assert m("liquid_weight_n", d) == pytest.approx(G)
    assert m("liftoff_force_jump_ratio", d) == pytest.approx(2.0 / G)
    assert m("liftoff_force_jump_n", d) == pytest.approx(2.0)
    assert m("climb_tank_force_ratio", d) == pytest.approx(1.0)
    assert m("climb_duration_s", d) == pytest.approx(8.0 - 3.1, abs=0.15)
    assert m("drag_opposes_vertical_motion", d) == pytest.approx(1.0)
    # climbed 1 m while accelerating (2 -> 3 s) then 2 m/s: 1 + 2 * (t - 3) at the end of the run
    assert m("altitude_above_home_m", d, (7.0, 7.0)) == pytest.approx(1.0 + 2.0 * 4.0, abs=0.05)
    assert m("max_rise_m", d, (2.5, 3.0)) == pytest.approx(0.75, abs=0.05)  # 1/2 a (t^2): 1 - 0.25
    assert m("max_rise_m", d, (0.0, 1.9)) == 0.0
    assert m("airborne_time_s", d) == pytest.approx(8.0 - 2.0, abs=0.03)
    off = takeoff_series(force_scale=1.02, drag_sign=-1.0)
    assert m("tank_force_rest_ratio", off) == pytest.approx(1.02)
    assert m("drag_opposes_vertical_motion", off) == pytest.approx(0.0)


def test_takeoff_metrics_without_liftoff_are_nan() -> None:
    d = takeoff_series()
    d.events = []
    assert math.isnan(m("liftoff_force_jump_ratio", d))


def spray_series(flow: float = 0.05, v0: float = 1.0) -> RunData:
    """Flow on at 2 s (off 1 s in a turn at 8..9 s); level falls linearly until empty."""
    dt = 0.02
    t = np.arange(0, 40.0, dt)
    cmd = np.where((t >= 2.0) & ~((t >= 8.0) & (t < 9.0)), flow, 0.0)
    level = np.maximum(0.0, v0 - np.cumsum(cmd) * dt + cmd[0] * dt)
    level = np.concatenate([[v0], np.maximum(0.0, v0 - np.cumsum(cmd[:-1]) * dt)])
    empty = t[np.argmax(level <= 1e-12)]
    cmd = np.where(level > 1e-12, cmd, cmd)  # commanded flow stays on after empty
    mass_tank = level * 1.0
    total = 2.32 + mass_tank
    w = 900.0 * np.sqrt(total / total[0]) + 3.0 * np.sin(2 * np.pi * t / 1.3)
    ts = {
        "t_s": t, "tank_flow_cmd_lps": cmd, "tank_level_l": level, "tank_mass_kg": mass_tank,
        "total_mass_kg": total, "on_ground": np.where(t < 1.0, 1.0, 0.0),
        "rotor1_w_radps": w, "rotor2_w_radps": w, "rotor3_w_radps": w, "rotor4_w_radps": w,
        "pos_enu_x_m": 0.5 * t, "pos_enu_y_m": np.full(t.shape, 0.2),
    }
    rows = [[(0.0, 0.0), (50.0, 0.0)], [(0.0, 3.0), (50.0, 3.0)]]
    return RunData(ts, events=[(1.0, "liftoff"), (float(empty), "tank_empty")],
                   context=MetricContext(gravity=G, rows_enu=rows))


def test_spray_metrics() -> None:
    d = spray_series()
    assert m("drain_time_pred_s", d) == pytest.approx(20.0, rel=1e-3)
    assert m("drain_time_s", d) == pytest.approx(20.0, rel=2e-3)
    assert m("drain_time_ratio", d) == pytest.approx(1.0, abs=2e-3)
    d.timeseries = {**d.timeseries, "tank_flow_lps": np.where(d.timeseries["tank_level_l"] > 0,
                                                              d.timeseries["tank_flow_cmd_lps"] * 0.9, 0.0)}
    assert m("spray_flow_ratio", d) == pytest.approx(0.9, abs=1e-3)
    assert m("rotor_mass_correlation", d) > 0.99
    assert m("hover_w_mass_exponent", d) == pytest.approx(0.5, abs=0.02)
    assert m("cross_track_rms_m", d) == pytest.approx(0.2)
    assert m("cross_track_max_m", d) == pytest.approx(0.2)


def test_drain_ratio_detects_wrong_rate() -> None:
    d = spray_series()
    ts = dict(d.timeseries)
    ts["tank_flow_cmd_lps"] = ts["tank_flow_cmd_lps"] * 1.1  # commanded 10 % more than what drained
    d.timeseries = ts
    assert m("drain_time_ratio", d) == pytest.approx(1.1, abs=0.01)


def test_point_polyline_distance() -> None:
    lines = [[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)]]
    d = point_polyline_distance(np.array([5.0, 12.0, -3.0, 11.0]), np.array([1.0, 5.0, -4.0, 12.0]), lines)
    np.testing.assert_allclose(d, [1.0, 2.0, 5.0, math.hypot(1, 2)])


def test_dominant_period() -> None:
    t = np.arange(0, 40, 0.02)
    y = 3.0 * np.sin(2 * np.pi * t / 8.0 + 0.4) + 0.1 * t + 0.3 * np.sin(2 * np.pi * t / 1.1)
    assert dominant_period(y, t) == pytest.approx(8.0, rel=0.01)
    assert math.isnan(dominant_period(np.ones_like(t), t))


def gust_series(theta: float = math.radians(4.0), lean_sign: float = 1.0) -> RunData:
    """Hover with wind towards +x (period 8 s); body z leans upwind (towards -x) by theta."""
    t = np.arange(0, 50, 0.02)
    wind = 3.0 + 1.5 * np.sin(2 * np.pi * t / 8.0)
    mass = np.full(t.shape, 3.0)
    q = quat_from_axis_angle((0.0, 1.0, 0.0), -lean_sign * theta)  # pitch about y: z axis tilts towards -x
    fx = np.full(t.shape, mass[0] * G * math.tan(theta))
    w = 950 + 8 * np.sin(2 * np.pi * t / 8.0 - 0.5)
    x = 0.25 * np.sin(2 * np.pi * t / 8.0)
    ts = {
        "t_s": t, "on_ground": np.where(t < 1.0, 1.0, 0.0), "total_mass_kg": mass,
        "wind_enu_x_mps": wind, "wind_enu_y_mps": np.zeros_like(t),
        "drag_enu_x_n": fx * 0.6, "drag_enu_y_n": np.zeros_like(t),
        "rotor_drag_flu_x_n": fx * 0.4 / math.cos(theta), "rotor_drag_flu_y_n": np.zeros_like(t),
        "rotor_drag_flu_z_n": np.zeros_like(t),
        "quat_x": np.full(t.shape, q[0]), "quat_y": np.full(t.shape, q[1]),
        "quat_z": np.full(t.shape, q[2]), "quat_w": np.full(t.shape, q[3]),
        "rotor1_w_radps": w, "rotor2_w_radps": w, "rotor3_w_radps": w, "rotor4_w_radps": w,
        "pos_enu_x_m": 10 + x, "pos_enu_y_m": np.full(t.shape, 5.0),
        "sp_pos_enu_x_m": np.full(t.shape, 10.0), "sp_pos_enu_y_m": np.full(t.shape, 5.0),
    }
    return RunData(ts, events=[(1.0, "liftoff")], context=MetricContext(gravity=G))


def test_gust_metrics() -> None:
    d = gust_series()
    assert m("hpos_error_max_m", d) == pytest.approx(0.25, abs=1e-3)
    assert m("hpos_error_rms_m", d) == pytest.approx(0.25 / math.sqrt(2), rel=0.03)
    assert m("wind_period_s", d) == pytest.approx(8.0, rel=0.02)
    assert m("rotor_wind_period_ratio", d) == pytest.approx(1.0, abs=0.02)
    # rotor drag is rotated from body to world: with the 0.4/cos split the total is m g tan(theta)
    assert m("tilt_into_wind_ratio", d) == pytest.approx(1.0, abs=0.02)
    assert m("tilt_mean_deg", d) == pytest.approx(4.0, abs=0.05)
    assert m("tilt_into_wind_fraction", d) == pytest.approx(1.0)
    wrong = gust_series(lean_sign=-1.0)
    assert m("tilt_into_wind_ratio", wrong) < -0.9
    assert m("tilt_into_wind_fraction", wrong) == pytest.approx(0.0)


def test_every_metric_documents_a_unit() -> None:
    for name, met in METRICS.items():
        assert met.unit and met.doc, name


def test_rotor_period_ignores_faster_attitude_oscillation() -> None:
    """A stronger 2.2 s oscillation of some rotors (attitude loop) must not hide the wind's 8 s period."""
    d = gust_series()
    ts = dict(d.timeseries)
    t = ts["t_s"]
    ts["rotor3_w_radps"] = ts["rotor3_w_radps"] + 25 * np.sin(2 * np.pi * t / 2.2)
    ts["rotor4_w_radps"] = ts["rotor4_w_radps"] - 25 * np.sin(2 * np.pi * t / 2.2)
    d.timeseries = ts
    assert m("rotor_wind_period_ratio", d) == pytest.approx(1.0, abs=0.02)
    assert m("rotor_period_s", d) == pytest.approx(2.2, rel=0.03)  # the unrestricted metric sees it


def test_meaningless_metrics_are_nan() -> None:
    """No wind -> no tilt-into-wind ratio (the drag of the vehicle's own motion is no wind); a constant
    mass -> no rotor-mass correlation (float jitter of the mass column is no mass change)."""
    calm = gust_series()
    ts = dict(calm.timeseries)
    ts["wind_enu_x_mps"] = np.full(ts["t_s"].shape, 0.2)  # below 0.5 m/s; the drag terms stay non-zero
    calm.timeseries = ts
    assert math.isnan(m("tilt_into_wind_ratio", calm))
    d = spray_series()
    ts = dict(d.timeseries)
    ts["total_mass_kg"] = 3.32 + 1e-9 * np.sin(ts["t_s"])  # constant up to float noise
    d.timeseries = ts
    assert math.isnan(m("rotor_mass_correlation", d))
