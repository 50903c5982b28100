"""Derived metrics for the thesis' chapter 5 experiments, computed from a run's time series.

Each metric is ``fn(data: RunData, window: (t0, t1) | None) -> float`` and is used in checks
as ``quantity: metric:<name>`` (the check's window is passed in; ``None`` = the metric's
default window, documented per metric). A metric that cannot be computed (no lift-off, no
samples in the window) returns NaN, which fails the check with a message.

Sign conventions: world ENU, z up. The tank force on the frame is ``m (g_vec - a)`` with
``g_vec = (0, 0, -g)``, so at rest ``tank_force_enu_z_n = -m g`` (downwards).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.frames import quat_rotate
from vinecli.missions.rundata import EventMissing, RunData
from vinecli.rows.geometry import point_polyline_distance

Window = tuple[float, float] | None
Polyline = Sequence[tuple[float, float]]


@dataclass(frozen=True)
class Metric:
    fn: Callable[[RunData, Window], float]
    unit: str
    doc: str


METRICS: dict[str, Metric] = {}


def metric(name: str, unit: str) -> Callable[[Callable[[RunData, Window], float]], Callable[[RunData, Window], float]]:
    """Register a metric under ``name`` (first docstring line becomes its description)."""

    def deco(fn: Callable[[RunData, Window], float]) -> Callable[[RunData, Window], float]:
        METRICS[name] = Metric(fn, unit, (fn.__doc__ or "").strip().splitlines()[0])
        return fn

    return deco


# ---------------------------------------------------------------- helpers
def _g(data: RunData) -> float:
    ctx = data.context
    return float(getattr(ctx, "gravity", STANDARD_GRAVITY) or STANDARD_GRAVITY)


def _try_event(data: RunData, kind: str) -> float | None:
    try:
        return data.event_time(kind)
    except EventMissing:
        return None


def _reduce(fn: Callable[[np.ndarray], Any], a: np.ndarray) -> float:
    """fn(a) as a float, NaN for an empty selection."""
    return float(fn(a)) if a.size else _nan()


def _rms(a: np.ndarray) -> float:
    """Root mean square, NaN for an empty selection."""
    return _reduce(lambda v: np.sqrt(np.mean(v * v)), a)


def _mask(data: RunData, window: Window, default: Window) -> np.ndarray:
    w = window if window is not None else default
    return data.window_mask(w)


def airborne_mask(columns: Mapping[str, np.ndarray]) -> np.ndarray:
    """The samples without ground contact (``on_ground`` < 0.5); all of them when the run has no ``on_ground``
    column. ``columns`` has ``t_s``."""
    if "on_ground" in columns:
        return np.asarray(columns["on_ground"], dtype=float) < 0.5
    return np.ones(np.shape(columns["t_s"]), dtype=bool)


def _airborne(data: RunData) -> np.ndarray:
    return airborne_mask(data.timeseries)


def _mean_rotor_speed(data: RunData) -> np.ndarray:
    cols = sorted((c for c in data.timeseries if re.fullmatch(r"rotor\d+_w_radps", c)), key=lambda c: int(c[5:-8]))
    if not cols:
        raise KeyError("rotor1_w_radps")
    return np.mean(np.vstack([data.column(c) for c in cols]), axis=0)


def _smooth(y: np.ndarray, t: np.ndarray, span_s: float) -> np.ndarray:
    """Centred moving average over ``span_s`` seconds (edges use the available samples)."""
    if y.size < 3:
        return y
    dt = float(np.median(np.diff(t)))
    n = max(1, int(round(span_s / dt)))
    if n <= 1:
        return y
    k = np.ones(n)
    num = np.convolve(y, k, mode="same")
    den = np.convolve(np.ones_like(y), k, mode="same")
    return num / den


def _nan() -> float:
    return float("nan")


# ---------------------------------------------------------------- takeoff (thesis §5.1)
@metric("liquid_weight_n", "N")
def liquid_weight_n(data: RunData, window: Window) -> float:
    """Weight of the liquid at the start of the window (default: the run start), N: tank_mass_kg * g."""
    m = data.column("tank_mass_kg")[_mask(data, window, None)]
    return float(m[0] * _g(data)) if m.size else _nan()


@metric("tank_force_rest_ratio", "1")
def tank_force_rest_ratio(data: RunData, window: Window) -> float:
    """Tank force at rest / liquid weight (1 = equal), medians over samples on the ground with |v_z| < 5 mm/s.
    Default window: the 1 s ending 0.3 s before lift-off (the whole run if it never lifts off)."""
    t = data.t
    if window is None:
        tl = _try_event(data, "liftoff")
        t_end = (tl - 0.3) if tl is not None else float(t[-1])
        window = (max(float(t[0]), t_end - 1.0), t_end)
    sel = data.window_mask(window)
    if data.has("on_ground"):
        sel &= data.column("on_ground") > 0.5
    if data.has("vel_enu_z_mps"):
        sel &= np.abs(data.column("vel_enu_z_mps")) < 0.005
    if not sel.any():
        return _nan()
    force_down = -data.column("tank_force_enu_z_n")[sel]
    weight = data.column("tank_mass_kg")[sel] * _g(data)
    w = float(np.median(weight))
    return float(np.median(force_down) / w) if w > 0 else _nan()


def _around_liftoff(data: RunData, window: Window) -> np.ndarray | None:
    """Mask of ``window``, by default lift-off -1 s .. +2 s; None if there is neither or it is empty."""
    if window is None:
        tl = _try_event(data, "liftoff")
        if tl is None:
            return None
        window = (tl - 1.0, tl + 2.0)
    sel = data.window_mask(window)
    return sel if sel.any() else None


@metric("liftoff_force_jump_ratio", "1")
def liftoff_force_jump_ratio(data: RunData, window: Window) -> float:
    """Peak tank force around lift-off over the liquid weight, minus 1 (0.2 = 20 % jump). Default window: lift-off -1 s .. +2 s."""
    sel = _around_liftoff(data, window)
    if sel is None:
        return _nan()
    force_down = -data.column("tank_force_enu_z_n")[sel]
    weight = data.column("tank_mass_kg")[sel] * _g(data)
    i = int(np.argmax(force_down))
    return float(force_down[i] / weight[i] - 1.0) if weight[i] > 0 else _nan()


@metric("liftoff_force_jump_n", "N")
def liftoff_force_jump_n(data: RunData, window: Window) -> float:
    """Largest |inertial part| of the tank force (z) around lift-off, N. Default window: lift-off -1 s .. +2 s."""
    sel = _around_liftoff(data, window)
    if sel is None:
        return _nan()
    if data.has("tank_force_inertial_enu_z_n"):
        f = data.column("tank_force_inertial_enu_z_n")[sel]
    else:
        f = data.column("tank_force_enu_z_n")[sel] + data.column("tank_mass_kg")[sel] * _g(data)
    return float(np.max(np.abs(f)))


def _steady_climb(data: RunData, window: Window, min_vz: float = 0.3, max_az: float = 0.3) -> np.ndarray:
    tl = _try_event(data, "liftoff")
    t = data.t
    default = (tl + 0.5, float(t[-1])) if tl is not None else None
    sel = _mask(data, window, default) & _airborne(data)
    vz = data.column("vel_enu_z_mps")
    az = data.column("acc_enu_z_mps2")
    az_s = _smooth(az, t, 0.2)
    return sel & (vz > min_vz) & (np.abs(az_s) < max_az)


@metric("climb_tank_force_ratio", "1")
def climb_tank_force_ratio(data: RunData, window: Window) -> float:
    """Tank force in steady climb (v_z > 0.3 m/s, |a_z| < 0.3 m/s² smoothed over 0.2 s) / liquid weight. Default window: lift-off +0.5 s .. end."""
    sel = _steady_climb(data, window)
    if not sel.any():
        return _nan()
    force_down = -data.column("tank_force_enu_z_n")[sel]
    weight = data.column("tank_mass_kg")[sel] * _g(data)
    return float(np.mean(force_down) / np.mean(weight)) if np.mean(weight) > 0 else _nan()


@metric("climb_duration_s", "s")
def climb_duration_s(data: RunData, window: Window) -> float:
    """Time spent in steady climb (same selection as climb_tank_force_ratio), s."""
    sel = _steady_climb(data, window)
    t = data.t
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    return float(np.count_nonzero(sel) * dt)


@metric("drag_opposes_vertical_motion", "1")
def drag_opposes_vertical_motion(data: RunData, window: Window, min_speed: float = 0.3) -> float:
    """Fraction of airborne samples with |v_z| > 0.3 m/s where the vertical wind drag opposes v_z (1 = always). Default: whole run."""
    sel = _mask(data, window, None) & _airborne(data)
    vz = data.column("vel_enu_z_mps")
    dz = data.column("drag_enu_z_n")
    sel &= np.abs(vz) > min_speed
    if not sel.any():
        return _nan()
    return float(np.mean(dz[sel] * vz[sel] < 0))


@metric("altitude_above_home_m", "m")
def altitude_above_home_m(data: RunData, window: Window) -> float:
    """Mean height of the vehicle above its start position (z - z at the first sample) over the window, m. Default: last 1 s."""
    t = data.t
    z = data.column("pos_enu_z_m")
    sel = _mask(data, window, (float(t[-1]) - 1.0, float(t[-1])))
    return float(np.mean(z[sel]) - z[0]) if sel.any() else _nan()


@metric("max_rise_m", "m")
def max_rise_m(data: RunData, window: Window) -> float:
    """Highest point of the vehicle above its height at the window start, m (0 = never rose).
    Default window: 0.5 s after the start (the spawn settle) to the end."""
    t = data.t
    z = data.column("pos_enu_z_m")
    sel = _mask(data, window, (float(t[0]) + 0.5, float(t[-1])))
    if not sel.any():
        return _nan()
    zs = z[sel]
    return float(np.max(zs) - zs[0])


@metric("airborne_time_s", "s")
def airborne_time_s(data: RunData, window: Window) -> float:
    """Time without ground contact (sum of the sample intervals with on_ground = 0), s.
    Default window: 0.5 s after the start (the spawn settle) to the end."""
    t = data.t
    sel = _mask(data, window, (float(t[0]) + 0.5, float(t[-1])))
    dt = np.diff(t, append=t[-1])
    return float(np.sum(dt[sel & _airborne(data)]))


# ---------------------------------------------------------------- spraying (thesis §5.2)
def _drain(data: RunData, window: Window) -> tuple[float, float]:
    """(measured flow-on time until empty, predicted volume / commanded flow), s."""
    t = data.t
    sel = _mask(data, window, None)
    cmd = data.column("tank_flow_cmd_lps")
    level = data.column("tank_level_l")
    on = sel & (cmd > 0)
    if not on.any():
        return _nan(), _nan()
    i0 = int(np.flatnonzero(on)[0])
    t_empty = _try_event(data, "tank_empty")
    if t_empty is None:
        return _nan(), _nan()
    dt = np.diff(t, append=t[-1])
    before = on & (t < t_empty - 1e-9)
    measured = float(np.sum(dt[before]))
    q = float(np.mean(cmd[before])) if before.any() else _nan()
    v0 = float(level[i0 - 1] if i0 > 0 else level[i0])
    return measured, (v0 / q if q > 0 else _nan())


@metric("drain_time_s", "s")
def drain_time_s(data: RunData, window: Window) -> float:
    """Time with the nozzle flow commanded on, from its first opening until the tank is empty, s."""
    return _drain(data, window)[0]


@metric("drain_time_pred_s", "s")
def drain_time_pred_s(data: RunData, window: Window) -> float:
    """Predicted drain time: level when the flow first opens / mean commanded flow while on, s."""
    return _drain(data, window)[1]


@metric("drain_time_ratio", "1")
def drain_time_ratio(data: RunData, window: Window) -> float:
    """Measured / predicted drain time (1 = the tank drains exactly at the commanded rate)."""
    m, p = _drain(data, window)
    return m / p if p and math.isfinite(p) else _nan()


@metric("spray_flow_ratio", "1")
def spray_flow_ratio(data: RunData, window: Window) -> float:
    """Delivered / commanded nozzle flow while the flow is commanded on and the tank has liquid (1 = the
    level falls at the commanded rate). Default: whole run."""
    sel = _mask(data, window, None)
    cmd = data.column("tank_flow_cmd_lps")
    flow = data.column("tank_flow_lps")
    level = data.column("tank_level_l")
    prev_level = np.concatenate([level[:1], level[:-1]])
    on = sel & (cmd > 0) & (prev_level > 1e-9) & (level > 1e-9)
    if not on.any() or cmd[on].sum() <= 0:
        return _nan()
    return float(flow[on].sum() / cmd[on].sum())


def _flight_window(data: RunData, window: Window, after_liftoff_s: float = 3.0) -> np.ndarray:
    t = data.t
    tl = _try_event(data, "liftoff")
    td = _try_event(data, "touchdown")
    t0 = (tl + after_liftoff_s) if tl is not None else float(t[0])
    t1 = td if (td is not None and td > t0) else float(t[-1])
    return _mask(data, window, (t0, t1)) & _airborne(data)


#: below this mass change (kg) over the window the mass counts as constant (no correlation to speak of)
MIN_MASS_CHANGE_KG = 1e-3
#: below this mean horizontal wind speed (m/s) over the window there is no wind to tilt into
MIN_WIND_MPS = 0.5


@metric("rotor_mass_correlation", "1")
def rotor_mass_correlation(data: RunData, window: Window) -> float:
    """Pearson correlation of the mean rotor speed (5 s moving average: manoeuvres out) with total mass,
    airborne; NaN (null) when the mass changes by less than 1 g. Default: lift-off +3 s .. touchdown."""
    sel = _flight_window(data, window)
    if np.count_nonzero(sel) < 10:
        return _nan()
    w = _smooth(_mean_rotor_speed(data)[sel], data.t[sel], 5.0)
    m = data.column("total_mass_kg")[sel]
    if np.std(w) == 0 or not np.ptp(m) >= MIN_MASS_CHANGE_KG:
        return _nan()
    return float(np.corrcoef(w, m)[0, 1])


@metric("hover_w_mass_exponent", "1")
def hover_w_mass_exponent(data: RunData, window: Window) -> float:
    """Slope of log(mean rotor speed, 5 s average) vs log(total mass), airborne (hover law: 0.5)."""
    sel = _flight_window(data, window)
    if np.count_nonzero(sel) < 10:
        return _nan()
    w = _smooth(_mean_rotor_speed(data)[sel], data.t[sel], 5.0)
    m = data.column("total_mass_kg")[sel]
    ok = (w > 0) & (m > 0)
    if np.ptp(np.log(m[ok])) < 1e-3:
        return _nan()
    return float(np.polyfit(np.log(m[ok]), np.log(w[ok]), 1)[0])


def _cross_track(data: RunData, window: Window) -> np.ndarray:
    rows = list(getattr(data.context, "rows_enu", ()) or ())
    if not rows:
        return np.array([])
    sel = _mask(data, window, None) & _airborne(data) & (data.column("tank_flow_cmd_lps") > 0)
    if not sel.any():
        return np.array([])
    return point_polyline_distance(data.column("pos_enu_x_m")[sel], data.column("pos_enu_y_m")[sel], rows)


@metric("cross_track_rms_m", "m")
def cross_track_rms_m(data: RunData, window: Window) -> float:
    """RMS horizontal distance to the nearest row while spraying (flow commanded, airborne), m."""
    d = _cross_track(data, window)
    return _rms(d)


@metric("cross_track_max_m", "m")
def cross_track_max_m(data: RunData, window: Window) -> float:
    """Largest horizontal distance to the nearest row while spraying, m."""
    d = _cross_track(data, window)
    return _reduce(np.max, d)


@metric("cross_track_p95_m", "m")
def cross_track_p95_m(data: RunData, window: Window) -> float:
    """95th percentile of the distance to the nearest row while spraying, m."""
    d = _cross_track(data, window)
    return _reduce(lambda a: np.percentile(a, 95), d)


# ---------------------------------------------------------------- wind (thesis §5.3)
def _hpos_error(data: RunData, window: Window) -> np.ndarray:
    sel = _flight_window(data, window, after_liftoff_s=5.0)
    if not sel.any():
        return np.array([])
    x, y = data.column("pos_enu_x_m")[sel], data.column("pos_enu_y_m")[sel]
    if data.has("sp_pos_enu_x_m"):
        sx, sy = data.column("sp_pos_enu_x_m")[sel], data.column("sp_pos_enu_y_m")[sel]
    else:
        sx, sy = np.full(x.shape, np.nan), np.full(y.shape, np.nan)
    bad = ~(np.isfinite(sx) & np.isfinite(sy))
    sx = np.where(bad, np.mean(x), sx)
    sy = np.where(bad, np.mean(y), sy)
    return np.hypot(x - sx, y - sy)


@metric("hpos_error_max_m", "m")
def hpos_error_max_m(data: RunData, window: Window) -> float:
    """Largest horizontal distance from the position setpoint (mean position where none), m. Default: lift-off +5 s .. touchdown."""
    e = _hpos_error(data, window)
    return _reduce(np.max, e)


@metric("hpos_error_rms_m", "m")
def hpos_error_rms_m(data: RunData, window: Window) -> float:
    """RMS horizontal distance from the position setpoint, m. Default: lift-off +5 s .. touchdown."""
    e = _hpos_error(data, window)
    return _rms(e)


def dominant_period(y: np.ndarray, t: np.ndarray, min_period: float = 0.2) -> float:
    """Period (s) of the strongest spectral peak of ``y`` (detrended, Hann, 16× zero-padded FFT,
    parabolic peak interpolation); ``y`` may be 2-D (one series per row: their power spectra are
    summed). NaN if there is no variation."""
    ys = np.atleast_2d(np.asarray(y, dtype=float))
    ok = np.all(np.isfinite(ys), axis=0)
    ys, t = ys[:, ok], np.asarray(t, dtype=float)[ok]
    if t.size < 8:
        return _nan()
    dt = float(np.median(np.diff(t)))
    nfft = 1 << int(math.ceil(math.log2(t.size * 16)))
    spec = np.zeros(nfft // 2 + 1)
    tt = t - t[0]
    for row in ys:
        yy = row - np.polyval(np.polyfit(tt, row, 1), tt)
        if np.allclose(yy, 0):
            continue
        spec += np.abs(np.fft.rfft(yy * np.hanning(yy.size), nfft)) ** 2
    if not spec.any():
        return _nan()
    spec = np.sqrt(spec)
    freq = np.fft.rfftfreq(nfft, dt)
    valid = (freq > 0) & (freq <= 1.0 / min_period)
    # ignore the lowest bins dominated by the window's own trend (< 1.5 cycles in the window)
    valid &= freq >= 1.5 / (t[-1] - t[0])
    if not valid.any():
        return _nan()
    idx = np.flatnonzero(valid)
    k = idx[int(np.argmax(spec[idx]))]
    if 0 < k < spec.size - 1:
        a, b, c = spec[k - 1], spec[k], spec[k + 1]
        den = a - 2 * b + c
        shift = 0.5 * (a - c) / den if den < 0 else 0.0  # a true local maximum only
        shift = max(-0.5, min(0.5, shift))
    else:
        shift = 0.0
    f = (k + shift) * (freq[1] - freq[0])
    return float(1.0 / f) if f > 0 else _nan()


def _wind_along_mean(data: RunData, sel: np.ndarray) -> np.ndarray:
    wx, wy = data.column("wind_enu_x_mps")[sel], data.column("wind_enu_y_mps")[sel]
    mx, my = float(np.mean(wx)), float(np.mean(wy))
    n = math.hypot(mx, my)
    if n < 1e-9:  # zero-mean wind: project on the principal direction
        cov = np.cov(np.vstack([wx, wy]))
        vals, vecs = np.linalg.eigh(cov)
        mx, my = vecs[:, -1]
        n = 1.0
    return (wx * mx + wy * my) / n


@metric("wind_period_s", "s")
def wind_period_s(data: RunData, window: Window) -> float:
    """Dominant period of the horizontal wind along its mean direction, s. Default: lift-off +5 s .. touchdown."""
    sel = _flight_window(data, window, after_liftoff_s=5.0)
    if np.count_nonzero(sel) < 8:
        return _nan()
    return dominant_period(_wind_along_mean(data, sel), data.t[sel])


def _rotor_period(data: RunData, window: Window, min_period: float) -> float:
    sel = _flight_window(data, window, after_liftoff_s=5.0)
    if np.count_nonzero(sel) < 8:
        return _nan()
    cols = [c for c in data.timeseries if re.fullmatch(r"rotor\d+_w_radps", c)]
    if not cols:
        raise KeyError("rotor1_w_radps")
    return dominant_period(np.vstack([data.column(c)[sel] for c in cols]), data.t[sel], min_period=min_period)


@metric("rotor_period_s", "s")
def rotor_period_s(data: RunData, window: Window) -> float:
    """Dominant period of the rotor speeds (power spectra of every rotor summed, periods >= 2 s: the
    wind band, not the controller's fast loops), s. Default: lift-off +5 s .. touchdown."""
    return _rotor_period(data, window, 2.0)


@metric("rotor_wind_period_ratio", "1")
def rotor_wind_period_ratio(data: RunData, window: Window) -> float:
    """Dominant period of the rotor speeds / that of the wind (1 = rotors oscillate with the wind); the
    rotor spectrum is searched at periods above half the wind's (the attitude loops' faster motions out)."""
    pw = wind_period_s(data, window)
    if not (math.isfinite(pw) and pw > 0):
        return _nan()
    return _rotor_period(data, window, 0.5 * pw) / pw


#: columns of the rotors' H-force (FLU) and of the attitude that turns it into ENU
_ROTOR_DRAG = ("rotor_drag_flu_x_n", "rotor_drag_flu_y_n", "rotor_drag_flu_z_n")
_QUAT = ("quat_x", "quat_y", "quat_z", "quat_w")


def horizontal_aero_force_enu(columns: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The horizontal aerodynamic force F_h on the vehicle per sample, (x, y) ENU, N: the links' wind drag
    ``drag_enu_{x,y}_n`` plus, when ``columns`` has ``rotor_drag_flu_{x,y,z}_n`` and ``quat_{x,y,z,w}``,
    the rotors' H-force rotated from body FLU to ENU."""
    fx = np.array(columns["drag_enu_x_n"], dtype=float)
    fy = np.array(columns["drag_enu_y_n"], dtype=float)
    if all(c in columns for c in (*_ROTOR_DRAG, *_QUAT)):
        qx, qy, qz, qw = (columns[c] for c in _QUAT)
        rdx, rdy, rdz = (columns[c] for c in _ROTOR_DRAG)
        for k in range(fx.size):
            q = (float(qx[k]), float(qy[k]), float(qz[k]), float(qw[k]))
            r = quat_rotate(q, (float(rdx[k]), float(rdy[k]), float(rdz[k])))
            fx[k] += r[0]
            fy[k] += r[1]
    return fx, fy


def predicted_tilt_rad(columns: Mapping[str, np.ndarray], gravity: float,
                       force_enu: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """The steady tilt the wind asks for, atan(|F_h| / (m g)) per sample, rad: F_h from
    :func:`horizontal_aero_force_enu` (or ``force_enu`` when already computed), m = ``total_mass_kg``,
    ``gravity`` in m/s² (positive; the run's world's)."""
    fx, fy = force_enu if force_enu is not None else horizontal_aero_force_enu(columns)
    return np.arctan2(np.hypot(fx, fy), np.asarray(columns["total_mass_kg"], dtype=float) * gravity)


def _tilt_terms(data: RunData, window: Window) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(tilt towards the upwind side of the horizontal aerodynamic force, rad; predicted
    atan(|F_h| / (m g)), rad; dot(body z horizontal, wind) sign) on the selected samples."""
    sel = _flight_window(data, window, after_liftoff_s=5.0)
    idx = np.flatnonzero(sel)
    if idx.size == 0:
        return np.array([]), np.array([]), np.array([])
    names = ["drag_enu_x_n", "drag_enu_y_n", "total_mass_kg", *_QUAT]
    if data.has("rotor_drag_flu_x_n"):
        names += _ROTOR_DRAG
    cols = {c: data.column(c)[idx] for c in names}
    qx, qy, qz, qw = (cols[c] for c in _QUAT)
    zb = np.empty((idx.size, 3))
    for k in range(idx.size):
        zb[k] = quat_rotate((float(qx[k]), float(qy[k]), float(qz[k]), float(qw[k])), (0.0, 0.0, 1.0))
    fx, fy = horizontal_aero_force_enu(cols)
    fmag = np.hypot(fx, fy)
    pred = predicted_tilt_rad(cols, _g(data), force_enu=(fx, fy))
    with np.errstate(invalid="ignore", divide="ignore"):
        ux, uy = -fx / fmag, -fy / fmag  # upwind direction: against the aerodynamic force
    along = np.arctan2(zb[:, 0] * ux + zb[:, 1] * uy, zb[:, 2])
    wx, wy = data.column("wind_enu_x_mps")[idx], data.column("wind_enu_y_mps")[idx]
    tt = data.t[idx]
    lean = _smooth(zb[:, 0], tt, 1.0) * wx + _smooth(zb[:, 1], tt, 1.0) * wy  # 1 s average: attitude jitter out
    strong = (np.hypot(wx, wy) > 0.5) & (pred >= math.radians(1.5))
    sign = np.where(strong, np.sign(-lean), np.nan)
    ok = fmag > 1e-6
    return along[ok], pred[ok], sign


@metric("tilt_into_wind_ratio", "1")
def tilt_into_wind_ratio(data: RunData, window: Window) -> float:
    """Mean tilt towards the upwind side / mean atan(F_h / (m g)); F_h = horizontal wind drag of the
    links plus the rotors' H-force (1 = the thesis' steady tilt; negative = leaning downwind). NaN
    (null) when the mean horizontal wind is below 0.5 m/s: no wind, nothing to tilt into."""
    sel = _flight_window(data, window, after_liftoff_s=5.0)
    if not sel.any():
        return _nan()
    wind = np.hypot(data.column("wind_enu_x_mps")[sel], data.column("wind_enu_y_mps")[sel])
    if not float(np.mean(wind)) >= MIN_WIND_MPS:
        return _nan()
    along, pred, _ = _tilt_terms(data, window)
    if along.size == 0 or np.mean(pred) <= 0:
        return _nan()
    return float(np.mean(along) / np.mean(pred))


@metric("tilt_into_wind_fraction", "1")
def tilt_into_wind_fraction(data: RunData, window: Window) -> float:
    """Fraction of the gusty samples (predicted steady tilt >= 1.5 deg) where the body z axis (1 s average)
    leans upwind (1 = always); below that the tilt is dominated by the position loop, not the wind."""
    _, _, sign = _tilt_terms(data, window)
    s = sign[np.isfinite(sign)]
    return float(np.mean(s > 0)) if s.size else _nan()


@metric("tilt_mean_deg", "deg")
def tilt_mean_deg(data: RunData, window: Window) -> float:
    """Mean measured tilt towards the upwind side, deg."""
    along, _, _ = _tilt_terms(data, window)
    return float(np.degrees(np.mean(along))) if along.size else _nan()


@metric("tilt_pred_deg", "deg")
def tilt_pred_deg(data: RunData, window: Window) -> float:
    """Mean predicted steady tilt atan(F_h / (m g)), deg."""
    _, pred, _ = _tilt_terms(data, window)
    return float(np.degrees(np.mean(pred))) if pred.size else _nan()



# ---------------------------------------------------------------- whole-field jobs (issue 13)
def _job_span(data: RunData) -> tuple[float, float] | None:
    """(first lift-off, last armed sample) in s, or None without a lift-off."""
    t0 = _try_event(data, "liftoff")
    if t0 is None or not data.has("armed"):
        return None
    armed = np.flatnonzero(data.column("armed") > 0.5)
    return (t0, float(data.t[armed[-1]])) if armed.size else None


def _rows_sprayed(data: RunData) -> tuple[float, float]:
    """(fraction, length m) of the context's rows that liquid was delivered over; computed once per RunData
    (a KD-tree over the spraying samples) for the metrics that need it."""
    from vinecli.missions.job import rows_sprayed

    cached = data.cache.get("rows_sprayed")
    if cached is None:
        cached = data.cache["rows_sprayed"] = rows_sprayed(data.timeseries, getattr(data.context, "rows_enu", ()) or ())
    return cached


@metric("sorties", "1")
def sorties(data: RunData, window: Window) -> float:
    """Number of sorties flown (take-offs of a refill job; 1 for a single flight), from the sortie column."""
    if not data.has("sortie"):
        return _nan()
    s = data.column("sortie")
    return float(np.nanmax(s)) if np.isfinite(s).any() else _nan()


@metric("job_time_s", "s")
def job_time_s(data: RunData, window: Window) -> float:
    """First lift-off to the last disarm of the run (ground service between sorties included), s."""
    span = _job_span(data)
    return span[1] - span[0] if span is not None else _nan()


@metric("rows_sprayed_fraction", "1")
def rows_sprayed_fraction(data: RunData, window: Window) -> float:
    """Share of the target rows' length that liquid was delivered over (within 0.5 m); NaN if nothing was sprayed."""
    if not data.has("tank_flow_lps") or not (np.nan_to_num(data.column("tank_flow_lps")) > 0).any():
        return _nan()
    return _rows_sprayed(data)[0]


@metric("area_rate_ha_per_h", "ha/h")
def area_rate_ha_per_h(data: RunData, window: Window) -> float:
    """Sprayed area (sprayed row length x row spacing) per hour of job time, ha/h."""
    from vinecli.rows.detect import row_spacing_m

    t_job = job_time_s(data, None)
    if not data.has("tank_flow_lps") or not t_job > 0:
        return _nan()
    length = _rows_sprayed(data)[1]
    return length * row_spacing_m(getattr(data.context, "rows_enu", ()) or ()) / 1e4 / (t_job / 3600.0)


@metric("litres_per_sortie", "L")
def litres_per_sortie(data: RunData, window: Window) -> float:
    """Liquid delivered (integral of tank_flow_lps) per sortie, L."""
    n = sorties(data, None)
    if not data.has("tank_flow_lps") or not n > 0:
        return _nan()
    from vinecli.missions.job import integral

    return integral(data.timeseries, "tank_flow_lps") / n if data.t.size > 1 else _nan()


# ---------------------------------------------------------------- spray deposition (docs/deposition.md)
def _reported(name: str) -> Callable[[RunData, Window], float]:
    def fn(data: RunData, window: Window) -> float:
        v = data.metrics.get(name)
        return float(v) if isinstance(v, (int, float)) else _nan()

    return fn


def _register_deposition() -> None:
    """The deposition metrics are computed once per run by the model (whole run; the window is ignored)."""
    from vinecli.missions.budget_metrics import BUDGET_METRICS
    from vinecli.missions.deposition_metrics import DEPOSIT_METRICS

    for name, (unit, doc) in {**DEPOSIT_METRICS, **BUDGET_METRICS}.items():
        METRICS[name] = Metric(_reported(name), unit, f"{doc} (whole run; window ignored)")


_register_deposition()
