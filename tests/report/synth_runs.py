"""Synthetic run directories that follow docs/architecture.md ("Time-series columns", "Run directory").

Physically plausible thesis-§5 signals for the report's tests and benchmark, without running
PyBullet: kinematics are built from time-stamped waypoints (piecewise linear, Gaussian-smoothed,
clamped to the terrain), and every other column is derived from them with the same laws the
simulator uses:

* tank force ``m (g - a)`` (ENU, g = (0, 0, -9.80665)), split into ``-m g`` and ``-m a``;
* link wind drag ``c |v_app| v_app`` with ``v_app = wind - velocity``;
* rotor speeds from the thrust the motion needs, ``w = sqrt(T / (n k_f))`` (hover law w ∝ sqrt(m)),
  commands from the first-order motor lag inverted;
* tilt into the wind ``atan(F_h / (m g))`` for the gust.

Checks are evaluated with the real :func:`vinecli.missions.checks.evaluate_checks` on check
definitions mirroring ``pipelines/missions/*.yaml`` (copied here so the fixtures do not move when a
mission file is tuned). Usable as a module from the tests (``from .synth_runs import ...``) and
from ``benchmarks/report.py`` (imported by path).
"""

from __future__ import annotations

import json
import math
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.frames import quat_from_euler, quat_rotate_inv, tilt_angle

G = 9.80665
K_F = 8.54858e-6  # N/(rad/s)^2, x500 rotor
K_D = 8.06428e-5  # rotor drag coefficient
K_M = 0.016  # reaction torque / thrust, m (shaft power k_m T w)
W_MAX = 1300.0  # rad/s, x500-sprayer
TAU_UP = 1.0 / 80.0
DRAG_C = 0.5 * 1.225 * (0.06 * 1.0 + 0.02 * 0.8)  # 0.5 rho sum(Cd A), kg/m
DRY_KG = 2.32
COM_Z = 0.12  # CoM above the ground when landed, m
ORIGIN = {"lat": 46.001, "lon": 7.001, "alt": 510.0}
ROWS_X = [-5.0 + 2.5 * i for i in range(6)]
ROW_Y = (-12.0, 12.0)
GEOFENCE = {"polygon_enu": [[-15.0, -25.0], [15.0, -25.0], [15.0, 25.0], [-15.0, 25.0]],
            "max_altitude_agl_m": 15.0, "max_horizontal_distance_m": None, "action": "hold"}

MISSIONS = ("takeoff", "overload", "spray", "gust")

#: check definitions (mirroring pipelines/missions/<name>.yaml)
CHECKS: dict[str, list[dict[str, Any]]] = {
    "takeoff": [
        {"name": "tank_force_at_rest", "description": "before lift-off the tank force equals the liquid weight (±1 %)",
         "quantity": "metric:tank_force_rest_ratio", "op": "between", "bound": [0.99, 1.01]},
        {"name": "liftoff_force_jump", "description": "the tank force jumps at lift-off (at least +5 % of the weight)",
         "quantity": "metric:liftoff_force_jump_ratio", "op": ">=", "bound": 0.05},
        {"name": "steady_climb_force", "description": "in the steady climb the tank force settles back to the weight (±3 %)",
         "quantity": "metric:climb_tank_force_ratio", "op": "between", "bound": [0.97, 1.03]},
        {"name": "drag_opposes_vertical_motion", "description": "with zero wind the vertical drag opposes v_z",
         "quantity": "metric:drag_opposes_vertical_motion", "op": ">=", "bound": 0.99},
        {"name": "altitude_reached", "description": "the hold altitude is the target within 0.3 m",
         "quantity": "metric:altitude_above_home_m", "window": ["phase:1", "phase_end:1"], "op": "between",
         "bound": [7.7, 8.3]},
        {"name": "landed", "description": "the vehicle is back on the ground at the end", "quantity": "on_ground",
         "reduce": "final", "op": "==", "bound": 1},
        {"name": "completed", "quantity": "status", "op": "==", "bound": "completed"},
    ],
    "overload": [
        {"name": "cannot_take_off", "description": "the run ends with status cannot_take_off", "quantity": "status",
         "op": "==", "bound": "cannot_take_off"},
        {"name": "stays_on_ground", "description": "the vehicle never leaves the ground", "quantity": "on_ground",
         "reduce": "min", "op": "==", "bound": 1},
        {"name": "no_climb", "description": "the vehicle does not rise more than 5 cm",
         "quantity": "metric:altitude_above_home_m", "window": ["start", "end"], "op": "<", "bound": 0.05},
    ],
    "spray": [
        {"name": "tank_emptied", "description": "the tank is empty at the end", "quantity": "tank_level_l",
         "reduce": "final", "op": "<=", "bound": 0.001},
        {"name": "drain_time", "description": "flow-on time until empty = volume / commanded flow (±2 %)",
         "quantity": "metric:drain_time_ratio", "op": "between", "bound": [0.98, 1.02]},
        {"name": "rotor_speed_follows_mass", "description": "mean rotor speed falls as the mass falls",
         "quantity": "metric:rotor_mass_correlation", "window": ["phase:1+3", "phase_end:1"], "op": ">=",
         "bound": 0.8},
        {"name": "on_the_rows", "description": "while spraying, 95 % of samples within 0.5 m of a row",
         "quantity": "metric:cross_track_p95_m", "op": "<=", "bound": 0.5},
        {"name": "spray_height", "description": "mean height above the terrain while spraying is 2 m (±0.4 m)",
         "quantity": "height_agl_m", "reduce": "mean", "window": ["phase:1+3", "phase_end:1"], "op": "between",
         "bound": [1.6, 2.4]},
        {"name": "completed", "quantity": "status", "op": "==", "bound": "completed"},
    ],
    "gust": [
        {"name": "holds_position", "description": "horizontal distance from the hold point stays under 1 m",
         "quantity": "metric:hpos_error_max_m", "window": ["phase:1+8", "phase_end:1"], "op": "<=", "bound": 1.0},
        {"name": "rotors_follow_wind_period", "description": "mean rotor speed oscillates with the wind's period",
         "quantity": "metric:rotor_wind_period_ratio", "window": ["phase:1+8", "phase_end:1"], "op": "between",
         "bound": [0.9, 1.1]},
        {"name": "tilts_into_wind", "description": "the body leans upwind in at least 95 % of the samples",
         "quantity": "metric:tilt_into_wind_fraction", "window": ["phase:1+8", "phase_end:1"], "op": ">=",
         "bound": 0.95},
        {"name": "tilt_magnitude", "description": "mean upwind tilt / mean atan(F_drag / (m g)) near 1",
         "quantity": "metric:tilt_into_wind_ratio", "window": ["phase:1+8", "phase_end:1"], "op": "between",
         "bound": [0.75, 1.25]},
        {"name": "completed", "quantity": "status", "op": "==", "bound": "completed"},
    ],
}

SUMMARY_METRICS = (
    "tank_force_rest_ratio", "liftoff_force_jump_ratio", "climb_tank_force_ratio", "drag_opposes_vertical_motion",
    "drain_time_ratio", "rotor_mass_correlation", "cross_track_rms_m", "hpos_error_max_m",
    "rotor_wind_period_ratio", "tilt_into_wind_ratio",
)


# ---------------------------------------------------------------- world
def terrain_height(x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
    """Gently rolling vineyard slope, m (ENU z)."""
    return 0.8 * np.sin(np.asarray(x) / 9.0) + 0.04 * np.asarray(y) + 0.3 * np.cos(np.asarray(y) / 7.0)


def terrain_preview() -> dict[str, np.ndarray]:
    x = np.linspace(-20.0, 20.0, 97)
    y = np.linspace(-30.0, 30.0, 129)
    xx, yy = np.meshgrid(x, y)
    return {"x": x, "y": y, "z": terrain_height(xx, yy)}


def vine_rows() -> list[list[list[float]]]:
    return [[[x, ROW_Y[0]], [x + 0.1, 0.0], [x + 0.2, ROW_Y[1]]] for x in ROWS_X]


# ---------------------------------------------------------------- kinematics helpers
def _smooth(a: np.ndarray, sigma_samples: float) -> np.ndarray:
    from scipy.ndimage import gaussian_filter1d

    return gaussian_filter1d(a, sigma_samples, axis=0, mode="nearest")


def _waypoints(t: np.ndarray, wps: Sequence[tuple[float, float, float, float]]) -> np.ndarray:
    """Piecewise-linear (t, x, y, z) waypoints sampled at ``t`` -> (n, 3)."""
    w = np.asarray(wps, dtype=float)
    return np.stack([np.interp(t, w[:, 0], w[:, k]) for k in (1, 2, 3)], axis=1)


def _kinematics(t: np.ndarray, pos_raw: np.ndarray, sigma_s: float, ground_clamp: bool = True
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Smoothed position, velocity, acceleration, terrain height, on_ground from raw waypoints."""
    dt = float(t[1] - t[0])
    pos = _smooth(pos_raw, sigma_s / dt)
    ground = terrain_height(pos[:, 0], pos[:, 1]) + COM_Z
    if ground_clamp:
        pos[:, 2] = np.maximum(pos[:, 2], ground)
    on_ground = pos[:, 2] <= ground + 1e-3
    vel = np.gradient(pos, dt, axis=0)
    acc = np.gradient(vel, dt, axis=0)
    still = on_ground & (np.abs(vel[:, 2]) < 1e-3)
    vel[still] = 0.0
    acc[still] = 0.0
    return pos, vel, acc, ground - COM_Z, on_ground


class _Run:
    """Collects columns, events and the final status of one synthetic run."""

    def __init__(self, mission: str, rate_hz: float, duration_s: float, seed: int) -> None:
        self.mission = mission
        self.rate = rate_hz
        self.t = np.round(np.arange(0.0, duration_s + 1e-9, 1.0 / rate_hz), 6)
        self.n = self.t.size
        self.rng = np.random.default_rng(seed)
        self.events: list[dict[str, Any]] = []
        self.status = "completed"
        self.detail = "all phases completed"

    def event(self, t: float, kind: str, message: str, **data: Any) -> None:
        self.events.append({"t_s": round(float(t), 6), "kind": kind, "message": message, "data": data})

    def phases(self, bounds: Sequence[float], names: Sequence[str]) -> np.ndarray:
        """phase_index column from phase start times (last phase runs to the end); emits phase events."""
        ph = np.zeros(self.n)
        for i, (t0, name) in enumerate(zip(bounds, names, strict=True)):
            ph[self.t >= t0 - 1e-9] = i
            self.event(t0, "phase", f"phase {i} ({name}) start", index=i, type=name, event="start")
            t_end = bounds[i + 1] if i + 1 < len(bounds) else float(self.t[-1])
            self.event(t_end, "phase", f"phase {i} ({name}) end", index=i, type=name, event="end")
        return ph


def _assemble(r: _Run, pos: np.ndarray, vel: np.ndarray, acc: np.ndarray, terrain_z: np.ndarray,
              on_ground: np.ndarray, wind: np.ndarray, level_l: np.ndarray, flow_cmd: np.ndarray,
              payload_kg: float, euler: np.ndarray, w_ground: np.ndarray, armed: np.ndarray,
              phase: np.ndarray, sp: np.ndarray) -> dict[str, np.ndarray]:
    """Every contract column from the kinematics, wind, tank and attitude."""
    n, dt, rng = r.n, 1.0 / r.rate, r.rng
    c: dict[str, np.ndarray] = {"t_s": r.t}
    for k, ax in enumerate("xyz"):
        c[f"pos_enu_{ax}_m"] = pos[:, k] + np.where(on_ground, 0.0, rng.normal(0, 0.004, n))
        c[f"vel_enu_{ax}_mps"] = vel[:, k]
        c[f"acc_enu_{ax}_mps2"] = acc[:, k]
    quats = np.array([quat_from_euler(*e) for e in euler])
    for k, ax in enumerate("xyzw"):
        c[f"quat_{ax}"] = quats[:, k]
    c["roll_rad"], c["pitch_rad"], c["yaw_rad"] = euler[:, 0], euler[:, 1], euler[:, 2]
    c["tilt_rad"] = np.array([tilt_angle(tuple(q)) for q in quats])
    omega = np.gradient(euler, dt, axis=0)
    for k, ax in enumerate("xyz"):
        c[f"omega_flu_{ax}_radps"] = omega[:, k]
    # air, drag
    app = wind - vel
    speed = np.linalg.norm(app, axis=1, keepdims=True)
    drag = DRAG_C * speed * app
    # tank
    level = np.clip(level_l, 0.0, None)
    m_tank = level * 1.0
    flow = np.where(level > 0, flow_cmd, 0.0)
    m_total = DRY_KG + payload_kg + m_tank
    # rotor speeds: thrust the motion needs (airborne) or the spool-up schedule (on the ground)
    app_h = np.column_stack([app[:, 0], app[:, 1], np.zeros(n)])
    w_air = np.zeros(n)
    for _ in range(3):  # rotor H-force grows with the rotor speed: a few fixed-point passes
        need = m_total[:, None] * (acc + np.array([0.0, 0.0, G])) - drag - K_D * 4.0 * w_air[:, None] * app_h
        w_air = np.sqrt(np.linalg.norm(need, axis=1) / (4.0 * K_F))
    # after the first lift-off, rotors on the ground spin down (idle while armed, then stopped)
    flown = np.cumsum(~on_ground) > 0
    w_ground = np.where(flown & on_ground, np.where(armed, 350.0, 0.0), w_ground)
    w_mean = np.where(on_ground, w_ground, np.minimum(w_air, W_MAX))
    rotors = np.empty((n, 4))
    for i in range(4):
        jitter = 1.0 + rng.normal(0.0, 0.0015, n) * (w_mean > 0)
        rotors[:, i] = np.clip(w_mean * jitter, 0.0, W_MAX)
    rotor_drag_world = K_D * rotors.sum(axis=1)[:, None] * app_h
    for i in range(4):
        w = rotors[:, i]
        c[f"rotor{i + 1}_w_radps"] = w
        c[f"rotor{i + 1}_cmd_radps"] = np.clip(w + TAU_UP * np.gradient(w, dt), 0.0, W_MAX)
        c[f"rotor{i + 1}_thrust_n"] = K_F * w ** 2
    c["thrust_total_n"] = sum(c[f"rotor{i + 1}_thrust_n"] for i in range(4))
    for k, ax in enumerate("xyz"):
        c[f"wind_enu_{ax}_mps"] = wind[:, k]
        c[f"air_app_enu_{ax}_mps"] = app[:, k]
        c[f"drag_enu_{ax}_n"] = drag[:, k]
    rd_body = np.array([quat_rotate_inv(tuple(q), tuple(v)) for q, v in zip(quats, rotor_drag_world, strict=True)])
    for k, ax in enumerate("xyz"):
        c[f"rotor_drag_flu_{ax}_n"] = rd_body[:, k]
    c["tank_level_l"] = level
    c["tank_mass_kg"] = m_tank
    c["tank_flow_lps"] = flow
    c["tank_flow_cmd_lps"] = flow_cmd
    g_vec = np.array([0.0, 0.0, -G])
    inertial = -m_tank[:, None] * acc
    for k, ax in enumerate("xyz"):
        c[f"tank_force_enu_{ax}_n"] = m_tank * g_vec[k] + inertial[:, k]
    c["tank_force_grav_enu_z_n"] = -m_tank * G
    for k, ax in enumerate("xyz"):
        c[f"tank_force_inertial_enu_{ax}_n"] = inertial[:, k]
    c["total_mass_kg"] = m_total
    spec_force = acc - g_vec
    imu = np.array([quat_rotate_inv(tuple(q), tuple(f)) for q, f in zip(quats, spec_force, strict=True)])
    for k, ax in enumerate("xyz"):
        c[f"imu_accel_flu_{ax}_mps2"] = imu[:, k] + rng.normal(0, 0.05, n)
        c[f"imu_gyro_flu_{ax}_radps"] = omega[:, k] + rng.normal(0, 0.003, n)
    c["baro_alt_m"] = pos[:, 2] + rng.normal(0, 0.05, n)
    lat0, lon0 = ORIGIN["lat"], ORIGIN["lon"]
    # small-area approximation (metres per degree) for the synthetic GNSS, sample-and-hold at 10 Hz
    hold = (np.arange(n) // max(1, int(r.rate // 10))) * max(1, int(r.rate // 10))
    c["gnss_lat_deg"] = (lat0 + pos[:, 1] / 111_132.0)[hold]
    c["gnss_lon_deg"] = (lon0 + pos[:, 0] / (111_320.0 * math.cos(math.radians(lat0))))[hold]
    c["gnss_alt_m"] = (ORIGIN["alt"] + pos[:, 2])[hold]
    c["terrain_z_m"] = terrain_z
    c["height_agl_m"] = pos[:, 2] - COM_Z - terrain_z
    c["on_ground"] = on_ground.astype(float)
    for k, ax in enumerate("xyz"):
        c[f"sp_pos_enu_{ax}_m"] = sp[:, k]
    c["phase_index"] = phase
    c["armed"] = armed.astype(float)
    # battery (flight/battery.py): shaft power k_m T w over 80 % + 10 W avionics from a 4S 74 Wh pack
    from vinecli.flight.battery import ocv_chen_rincon_mora

    p_load = K_M * sum(c[f"rotor{i + 1}_thrust_n"] * rotors[:, i] for i in range(4)) / 0.8 + 10.0
    soc = np.clip(1.0 - np.cumsum(p_load) * dt / (74.0 * 3600.0), 0.0, 1.0)
    e = 4.0 * np.array([ocv_chen_rincon_mora(float(x)) for x in soc])
    cur = 2.0 * p_load / (e + np.sqrt(e * e - 4.0 * 0.02 * p_load))
    c["battery_soc"], c["battery_voltage_v"], c["battery_current_a"] = soc, e - 0.02 * cur, cur
    c["power_elec_w"] = e * cur
    c["sortie"] = np.ones(n)
    return c


def _liftoff_touchdown(r: _Run, on_ground: np.ndarray, pos: np.ndarray) -> None:
    d = np.diff(on_ground.astype(int))
    for i in np.flatnonzero(d == -1):
        r.event(r.t[i + 1], "liftoff", f"lift-off at {r.t[i + 1]:.3f} s", z_m=float(pos[i + 1, 2]))
    for i in np.flatnonzero(d == 1):
        r.event(r.t[i + 1], "touchdown", f"touchdown at {r.t[i + 1]:.3f} s", z_m=float(pos[i + 1, 2]))


def _spool(t: np.ndarray, t_arm: float, t_full: float, w_full: float) -> np.ndarray:
    return np.clip((t - t_arm) / (t_full - t_arm), 0.0, 1.0) * w_full * (t >= t_arm)


# ---------------------------------------------------------------- missions
def _takeoff(seed: int) -> tuple[_Run, dict[str, np.ndarray], float]:
    r = _Run("takeoff", 100.0, 20.0, seed)
    x0, y0 = 0.0, -8.0
    z0 = float(terrain_height(x0, y0)) + COM_Z
    t_arm, t_lo = 1.5, 2.5
    t_top = t_lo + 4.0  # 8 m at 2 m/s
    t_land = t_top + 3.5
    t_down = t_land + 8.0  # 8 m at 1 m/s
    raw = _waypoints(r.t, [(0, x0, y0, z0), (t_lo, x0, y0, z0),
                           (t_top, x0, y0, z0 + 8.0), (t_land, x0, y0, z0 + 8.0), (t_down, x0, y0, z0 - 0.3),
                           (20.0, x0, y0, z0 - 0.3)])
    pos, vel, acc, tz, og = _kinematics(r.t, raw, 0.22)
    wind = np.zeros((r.n, 3))
    level = np.full(r.n, 1.0)
    euler = np.column_stack([r.rng.normal(0, 0.004, r.n) * ~og, r.rng.normal(0, 0.004, r.n) * ~og, np.zeros(r.n)])
    armed = (r.t >= t_arm) & (r.t < t_down + 1.0)
    w_ground = _spool(r.t, t_arm, t_lo, 960.0) * armed
    phase = r.phases([0.0, t_top + 0.6, t_top + 3.6], ["takeoff", "hold", "land"])
    sp = np.column_stack([np.full(r.n, x0), np.full(r.n, y0), np.where(r.t < t_land, z0 + 8.0, z0)])
    r.event(t_arm, "arming", "armed", armed=True)
    _liftoff_touchdown(r, og, pos)
    cols = _assemble(r, pos, vel, acc, tz, og, wind, level, np.zeros(r.n), 0.0, euler, w_ground, armed, phase, sp)
    return r, cols, 0.0


def _overload(seed: int) -> tuple[_Run, dict[str, np.ndarray], float]:
    r = _Run("overload", 50.0, 12.0, seed)
    x0, y0 = 2.0, -8.0
    z0 = float(terrain_height(x0, y0)) + COM_Z
    pos = np.tile([x0, y0, z0], (r.n, 1)).astype(float)
    og = np.ones(r.n, dtype=bool)
    zeros = np.zeros((r.n, 3))
    armed = r.t >= 1.5
    w_ground = _spool(r.t, 1.5, 3.5, W_MAX)
    phase = r.phases([0.0], ["takeoff"])
    sp = np.column_stack([np.full(r.n, x0), np.full(r.n, y0), np.full(r.n, z0 + 5.0)])
    r.event(1.5, "arming", "armed", armed=True)
    r.status = "cannot_take_off"
    r.detail = "cannot take off: thrust-limited (thrust-to-weight below 1)"
    cols = _assemble(r, pos, zeros, zeros, pos[:, 2] - COM_Z, og, zeros, np.full(r.n, 1.0), np.zeros(r.n), 3.5,
                     np.zeros((r.n, 3)), w_ground, armed, phase, sp)
    return r, cols, 3.5


def _spray(seed: int) -> tuple[_Run, dict[str, np.ndarray], float]:
    rate, speed, flow_lps = 50.0, 1.5, 0.05
    x0, y0 = ROWS_X[0], ROW_Y[0]
    z_of = lambda x, y, h: float(terrain_height(x, y)) + COM_Z + h  # noqa: E731
    t_arm, t_lo = 1.0, 2.0
    t = t_lo + 2.0  # 3 m at 1.5 m/s
    wps: list[tuple[float, float, float, float]] = [(0.0, x0, y0, z_of(x0, y0, 0.0)), (t_lo, x0, y0, z_of(x0, y0, 0.0)),
                                                    (t, x0, y0, z_of(x0, y0, 3.0))]
    t += 1.0
    wps.append((t, x0, y0, z_of(x0, y0, 2.0)))
    flow_on: list[tuple[float, float]] = []
    left = 1.0 / flow_lps  # s of flow in a full tank
    t_spray = t
    i = 0
    while left > 1e-9:
        x = ROWS_X[i % len(ROWS_X)]
        ya, yb = (ROW_Y if i % 2 == 0 else ROW_Y[::-1])
        dur = abs(yb - ya) / speed
        use = min(dur, left)
        # the row, sampled every metre so the height follows the terrain
        steps = max(2, int(abs(yb - ya) * use / dur))
        for k in range(1, steps + 1):
            y = ya + (yb - ya) * (use / dur) * k / steps
            wps.append((t + use * k / steps, x + 0.1 * (y - ya) / 24.0, y, z_of(x, y, 2.0)))
        flow_on.append((t, t + use))
        t += use
        left -= use
        if left > 1e-9:  # turn to the next row (2.5 m at 1.5 m/s, flow off)
            xn = ROWS_X[(i + 1) % len(ROWS_X)]
            t += 2.5 / speed
            wps.append((t, xn, yb, z_of(xn, yb, 2.0)))
        i += 1
    t_empty = t
    xe, ye, ze = wps[-1][1:]
    t += 1.5
    wps.append((t, xe, ye, ze))
    t_land = t
    t += (ze - z_of(xe, ye, -0.3)) / 1.0
    wps.append((t, xe, ye, z_of(xe, ye, -0.3)))
    duration = t + 1.5
    wps.append((duration, xe, ye, z_of(xe, ye, -0.3)))
    r = _Run("spray", rate, duration, seed)
    raw = _waypoints(r.t, wps)
    pos, vel, acc, tz, og = _kinematics(r.t, raw, 0.35)
    flow_cmd = np.zeros(r.n)
    for a, b in flow_on:
        flow_cmd[(r.t >= a) & (r.t < b)] = flow_lps
    level = 1.0 - np.concatenate([[0.0], np.cumsum(flow_cmd[:-1]) / rate])
    level[level < 1e-9] = 0.0
    yaw = np.unwrap(np.arctan2(vel[:, 1], vel[:, 0] + 1e-9))
    yaw = np.where(np.hypot(vel[:, 0], vel[:, 1]) > 0.3, yaw, np.nan)
    yaw = np.asarray(_ffill(yaw, 0.0))
    hacc = acc[:, :2]
    pitch = np.arctan(hacc[:, 0] / G) * ~og  # small-angle: tilt towards the acceleration (yaw ~ along track)
    roll = -np.arctan(hacc[:, 1] / G) * ~og
    euler = np.column_stack([roll, pitch, np.where(og, yaw[0], yaw)])
    armed = (r.t >= t_arm) & (r.t < duration - 1.0)
    w_ground = _spool(r.t, t_arm, t_lo, 970.0) * armed
    phase = r.phases([0.0, t_spray, t_land], ["takeoff", "spray", "land"])
    sp = raw.copy()
    sp[r.t < t_arm] = np.nan
    r.event(t_arm, "arming", "armed", armed=True)
    _liftoff_touchdown(r, og, pos)
    r.event(t_empty, "tank_empty", f"tank empty at {t_empty:.3f} s")
    cols = _assemble(r, pos, vel, acc, tz, og, np.zeros((r.n, 3)), level, flow_cmd, 0.0, euler, w_ground, armed,
                     phase, sp)
    return r, cols, 0.0


def _gust(seed: int, hold_error_m: float = 0.25) -> tuple[_Run, dict[str, np.ndarray], float]:
    r = _Run("gust", 50.0, 56.0, seed)
    x0, y0 = 0.0, 5.0
    z0 = float(terrain_height(x0, y0)) + COM_Z
    t_arm, t_lo = 1.0, 2.0
    t_hold = t_lo + 3.0
    t_land = t_hold + 40.0
    t_down = t_land + 5.5
    wind_x = 3.0 + 2.0 * np.sin(2 * np.pi * r.t / 8.0)
    # the position loop lets the vehicle drift downwind a little with the gust (lagging)
    drift = hold_error_m * np.sin(2 * np.pi * (r.t - 1.0) / 8.0)
    raw = _waypoints(r.t, [(0, x0, y0, z0), (t_lo, x0, y0, z0),
                           (t_hold, x0, y0, z0 + 5.0), (t_land, x0, y0, z0 + 5.0), (t_down, x0, y0, z0 - 0.3),
                           (56.0, x0, y0, z0 - 0.3)])
    air = (r.t > t_lo) & (r.t < t_down)
    raw[:, 0] += np.where(air, drift, 0.0)
    pos, vel, acc, tz, og = _kinematics(r.t, raw, 0.3)
    wind = np.column_stack([wind_x, np.zeros(r.n), np.zeros(r.n)])
    app = wind - vel
    m = DRY_KG + 1.0
    w_hover = math.sqrt(m * G / (4 * K_F))
    f_h = DRAG_C * np.abs(app[:, 0]) * app[:, 0] + K_D * 4 * w_hover * app[:, 0]
    lag = int(0.3 * r.rate)
    pitch = -np.arctan((np.roll(f_h, lag) - m * acc[:, 0]) / (m * G))  # nose up = lean upwind (wind blows +x)
    pitch[:lag] = pitch[lag]
    roll = r.rng.normal(0, 0.006, r.n)
    euler = np.column_stack([roll * ~og, pitch * ~og, np.zeros(r.n)])
    armed = (r.t >= t_arm) & (r.t < t_down + 1.0)
    w_ground = _spool(r.t, t_arm, t_lo, 960.0) * armed
    phase = r.phases([0.0, t_hold, t_land], ["takeoff", "hold", "land"])
    sp = np.column_stack([np.full(r.n, x0), np.full(r.n, y0), np.where(r.t < t_land, z0 + 5.0, z0)])
    r.event(t_arm, "arming", "armed", armed=True)
    _liftoff_touchdown(r, og, pos)
    cols = _assemble(r, pos, vel, acc, tz, og, wind, np.full(r.n, 1.0), np.zeros(r.n), 0.0, euler, w_ground, armed,
                     phase, sp)
    return r, cols, 0.0


def _ffill(a: np.ndarray, first: float) -> list[float]:
    out, last = [], first
    for v in a:
        last = last if not np.isfinite(v) else float(v)
        out.append(last)
    return out


_BUILDERS = {"takeoff": _takeoff, "overload": _overload, "spray": _spray, "gust": _gust}


# ---------------------------------------------------------------- writing
def _evaluate(mission: str, r: _Run, cols: dict[str, np.ndarray], check_overrides: dict[str, dict[str, Any]] | None
              ) -> tuple[list[dict[str, Any]], dict[str, float | None]]:
    from vinecli.missions.checks import evaluate_checks
    from vinecli.missions.metrics import METRICS
    from vinecli.missions.rundata import MetricContext, RunData
    from vinecli.specs.mission import CheckSpec

    defs = [dict(d) for d in CHECKS[mission]]
    for d in defs:
        d.update((check_overrides or {}).get(d["name"], {}))
    specs = [CheckSpec.model_validate(d) for d in defs]
    rows = [[tuple(p) for p in row] for row in vine_rows()]
    data = RunData(timeseries=cols, events=[(e["t_s"], e["kind"]) for e in r.events], status=r.status,
                   metrics={}, context=MetricContext(gravity=G, rows_enu=rows))
    checks = [c.to_dict() for c in evaluate_checks(specs, data)]
    metrics: dict[str, float | None] = {}
    for name in SUMMARY_METRICS:
        try:
            v = float(METRICS[name].fn(data, None))
        except (KeyError, ValueError, IndexError):
            v = float("nan")
        metrics[name] = v if math.isfinite(v) else None
    return checks, metrics


def write_run(runs_dir: Path, mission: str, *, run_id: str | None = None, case: str | None = None, seed: int = 0,
              check_overrides: dict[str, dict[str, Any]] | None = None, **kwargs: Any) -> Path:
    """Write ``runs_dir/<run_id>/`` for one synthetic ``mission`` (takeoff, overload, spray, gust).

    ``check_overrides`` replaces fields of named checks (e.g. ``{"holds_position": {"bound": 0.1}}``
    to make a check fail); ``kwargs`` go to the mission builder (gust: ``hold_error_m``).
    """
    from vinecli.runs import rundir

    r, cols, payload = _BUILDERS[mission](seed, **kwargs)
    r.event(float(r.t[-1]), "status", f"{r.status}: {r.detail}", status=r.status, detail=r.detail)
    checks, metrics = _evaluate(mission, r, cols, check_overrides)
    liftoff = next((e["t_s"] for e in r.events if e["kind"] == "liftoff"), None)
    touchdown = next((e["t_s"] for e in r.events if e["kind"] == "touchdown"), None)
    empty = next((e["t_s"] for e in r.events if e["kind"] == "tank_empty"), None)
    metrics.update(liftoff_s=liftoff, touchdown_s=touchdown, tank_empty_s=empty,
                   total_mass_start_kg=float(cols["total_mass_kg"][0]), payload_kg=payload)
    run_id = run_id or f"{mission}-s{seed}"
    sim_t = float(r.t[-1])
    wall = round(sim_t / (25.0 + 5.0 * (seed % 3)), 4)
    summary = {
        "run_id": run_id, "case": case or run_id, "mission": mission,
        "description": f"synthetic {mission} run (tests/report/synth_runs.py)", "vehicle": "x500-sprayer",
        "world": {"name": "synthetic-vineyard", "dir": "/nonexistent/synthetic-vineyard", "origin": ORIGIN,
                  "rows_enu": vine_rows(), "geofence": GEOFENCE},
        "autopilot": "builtin", "truth": False, "seed": seed, "status": r.status, "status_message": r.detail,
        "passed": all(c["passed"] for c in checks), "sim_time_s": sim_t, "wall_time_s": wall,
        "real_time_factor": round(sim_t / wall, 3), "record_rate_hz": r.rate, "checks": checks, "metrics": metrics,
        "started_utc": "2026-11-22T08:00:00+00:00",
    }
    out = Path(runs_dir) / run_id
    out.mkdir(parents=True, exist_ok=True)
    rundir.write_timeseries(out / rundir.TIMESERIES, cols, {"run_id": run_id, "mission": mission, "seed": str(seed),
                                                             "units": "SI; frame in names"})
    with open(out / rundir.EVENTS, "w", encoding="utf-8") as f:
        for e in sorted(r.events, key=lambda e: e["t_s"]):
            f.write(json.dumps(e) + "\n")
    (out / rundir.MISSION).write_text(f"name: {mission}\ndescription: synthetic\n", encoding="utf-8")
    rundir.write_preview(out / rundir.PREVIEW, terrain_preview())
    if mission == "spray":  # the real deposition model on the synthetic flight
        summary["metrics"].update(_write_deposition(out, cols, r.rate))
    rundir.write_summary(out / rundir.SUMMARY, summary)
    (out / "manifest.json").write_text(json.dumps({"tool": "vinecli", "command": "synthetic"}) + "\n")
    return out


def _write_deposition(out: Path, cols: dict[str, np.ndarray], rate_hz: float) -> dict[str, float]:
    """deposition.tif/.json of the synthetic spray flight (vinecli.spray.deposition on its columns)."""
    from types import SimpleNamespace

    from vinecli.geo import GeoOrigin
    from vinecli.runs.deposition_out import evaluate_deposition, write_deposition
    from vinecli.sim.spray_deposit import DepositionResult
    from vinecli.specs.mission import MissionSpec
    from vinecli.specs.wind import WindSpec
    from vinecli.spray.deposit_grid import grid_for, rasterise_discs
    from vinecli.spray.deposition import DepositionConfig, SprayEmitter, SprayerGeometry, transport
    from vinecli.spray.nozzle_pattern import inner_radius
    from vinecli.vehicle import load_vehicle

    veh = load_vehicle("x500-sprayer")
    dt = 1.0 / rate_hz
    em = SprayEmitter()
    names = ("t_s", "pos_enu_x_m", "pos_enu_y_m", "pos_enu_z_m", "quat_x", "quat_y", "quat_z", "quat_w", "vel_enu_x_mps",
             "vel_enu_y_mps", "vel_enu_z_mps", "wind_enu_x_mps", "wind_enu_y_mps", "wind_enu_z_mps", "thrust_total_n")
    for i in np.flatnonzero(cols["tank_flow_lps"] > 0):
        em.emit((*(float(cols[n][i]) for n in names), float(cols["tank_flow_lps"][i]) * dt, 0.0))
    cfg = DepositionConfig()
    par = transport(em.array(), SprayerGeometry.from_vehicle(veh, 1.225), terrain_height, WindSpec(), 1.225, 0, cfg)
    rows = [[tuple(p) for p in r] for r in vine_rows()]
    grid = grid_for(par.path_xy, [p for r in rows for p in r], (-20.0, -30.0, 20.0, 30.0), 0.1, 15.0, 6_000_000)
    vol, off = rasterise_discs(grid, par.x, par.y, par.vol, par.radius, inner=inner_radius(par.radius, par.ring_r))
    dep = DepositionResult(grid=grid, volume_l=vol, valid=np.ones(vol.shape, bool), parcels=par, emitted_l=par.emitted_l,
                           on_grid_l=float(vol.sum()), off_grid_l=off, config=cfg, transport_s=0.0, sprayer={})
    spec = MissionSpec.model_validate({"name": "spray", "phases": [
        {"type": "spray", "rows": [list(map(list, r)) for r in rows], "height_agl_m": 2.0, "speed_mps": 2.0,
         "flow_lps": float(np.max(cols["tank_flow_lps"]))}]})
    world = SimpleNamespace(origin=GeoOrigin.from_dict(ORIGIN), canopy_width_m=0.6, vine_rows_enu=rows)
    fence = SimpleNamespace(polygon_enu=GEOFENCE["polygon_enu"])
    metrics, doc = evaluate_deposition(dep, spec, veh, world, rows, fence)
    write_deposition(out, dep, world, None, doc)
    # the spray budget of the same flight over BBCH 75 hedges on the rows, 20 °C / 60 %
    from vinecli.runs.budget_out import evaluate_budget, write_budget
    from vinecli.specs.canopy import CanopySpec
    from vinecli.world.canopy_build import resolve_canopy

    canopy = resolve_canopy(CanopySpec(bbch=75), rows, None)
    dep.geometry, dep.wind_xy = SprayerGeometry.from_vehicle(veh, 1.225), (0.0, 0.0)
    world.gravity, world.air, world.canopy_model = 9.80665, (20.0, 60.0), lambda: canopy
    budget = evaluate_budget(dep, world, rows, metrics["nominal_rate_lpha"])
    write_budget(out, budget, dep, world, None)
    return {**metrics, **budget.metrics}


def write_batch(runs_dir: Path, cases: Sequence[dict[str, Any]], pipeline: str = "synthetic") -> Path:
    """Write ``runs_dir/batch.json`` for cases ``{case, run_id, status, passed, error, seed}``."""
    runs_dir = Path(runs_dir)
    runs_dir.mkdir(parents=True, exist_ok=True)
    data = {"pipeline": pipeline, "passed": all(c.get("passed") for c in cases), "cases": list(cases)}
    (runs_dir / "batch.json").write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    return runs_dir / "batch.json"


def write_ci_batch(runs_dir: Path, *, seed: int = 0, fail: dict[str, dict[str, dict[str, Any]]] | None = None,
                   errored: Sequence[str] = (), gust_hold_error_m: float = 0.25) -> Path:
    """The four chapter-5 missions as a batch (case = mission name) plus ``batch.json``.

    ``fail``: per-mission check overrides; ``errored``: extra case names recorded as errors (no run dir).
    """
    cases = []
    for mission in MISSIONS:
        kw = {"hold_error_m": gust_hold_error_m} if mission == "gust" else {}
        d = write_run(runs_dir, mission, run_id=mission, case=mission, seed=seed,
                      check_overrides=(fail or {}).get(mission), **kw)
        s = json.loads((d / "summary.json").read_text())
        cases.append({"case": mission, "run_id": mission, "status": s["status"], "passed": s["passed"], "error": None,
                      "seed": seed, "sim_time_s": s["sim_time_s"], "wall_time_s": s["wall_time_s"],
                      "real_time_factor": s["real_time_factor"],
                      "failed_checks": [c["name"] for c in s["checks"] if not c["passed"]]})
    for name in errored:
        cases.append({"case": name, "run_id": name, "status": "error", "passed": False,
                      "error": "worker crashed (process died)", "seed": seed})
    write_batch(runs_dir, cases, pipeline="ci")
    return Path(runs_dir)


def clone_batch(src: Path, dst: Path, n: int, *, fail_every: int = 0) -> Path:
    """A large batch of ``n`` runs copied from the runs of ``src`` (round robin), each with its own id and seed.

    Every ``fail_every``-th run gets its first check marked failed (for pagination/sorting tests and the benchmark).
    """
    src, dst = Path(src), Path(dst)
    bases = sorted(p.parent for p in src.glob("*/summary.json"))
    dst.mkdir(parents=True, exist_ok=True)
    cases = []
    for k in range(n):
        base = bases[k % len(bases)]
        s = json.loads((base / "summary.json").read_text())
        run_id = f"{s['mission']}-{k:04d}-s{k}"
        out = dst / run_id
        shutil.copytree(base, out)
        s.update(run_id=run_id, case=run_id, seed=k)
        if fail_every and k % fail_every == fail_every - 1 and s["checks"]:
            c = s["checks"][0]
            c["passed"] = False
            c["message"] = f"{c['message']} (marked failed by clone_batch)"
            s["passed"] = False
        (out / "summary.json").write_text(json.dumps(s, indent=1) + "\n")
        cases.append({"case": run_id, "run_id": run_id, "status": s["status"], "passed": s["passed"], "error": None,
                      "seed": k})
    write_batch(dst, cases, pipeline="synthetic-large")
    return dst
