"""Wind metrics (thesis §5.3): holding position, rotor speeds and wind with the same period, the tilt
into the wind against the predicted steady tilt."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping

import numpy as np

from vinecli.frames import quat_rotate
from vinecli.missions.metrics.base import Window, flight_window, gravity_of, metric, nan, reduce_or_nan, rms, smooth
from vinecli.missions.rundata import RunData

MIN_WIND_MPS = 0.5


# ---------------------------------------------------------------- wind (thesis §5.3)
def _hpos_error(data: RunData, window: Window) -> np.ndarray:
    sel = flight_window(data, window, after_liftoff_s=5.0)
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
    return reduce_or_nan(np.max, e)


@metric("hpos_error_rms_m", "m")
def hpos_error_rms_m(data: RunData, window: Window) -> float:
    """RMS horizontal distance from the position setpoint, m. Default: lift-off +5 s .. touchdown."""
    e = _hpos_error(data, window)
    return rms(e)


def dominant_period(y: np.ndarray, t: np.ndarray, min_period: float = 0.2) -> float:
    """Period (s) of the strongest spectral peak of ``y`` (detrended, Hann, 16× zero-padded FFT,
    parabolic peak interpolation); ``y`` may be 2-D (one series per row: their power spectra are
    summed). NaN if there is no variation."""
    ys = np.atleast_2d(np.asarray(y, dtype=float))
    ok = np.all(np.isfinite(ys), axis=0)
    ys, t = ys[:, ok], np.asarray(t, dtype=float)[ok]
    if t.size < 8:
        return nan()
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
        return nan()
    spec = np.sqrt(spec)
    freq = np.fft.rfftfreq(nfft, dt)
    valid = (freq > 0) & (freq <= 1.0 / min_period)
    # ignore the lowest bins dominated by the window's own trend (< 1.5 cycles in the window)
    valid &= freq >= 1.5 / (t[-1] - t[0])
    if not valid.any():
        return nan()
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
    return float(1.0 / f) if f > 0 else nan()


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
    sel = flight_window(data, window, after_liftoff_s=5.0)
    if np.count_nonzero(sel) < 8:
        return nan()
    return dominant_period(_wind_along_mean(data, sel), data.t[sel])


def _rotor_period(data: RunData, window: Window, min_period: float) -> float:
    sel = flight_window(data, window, after_liftoff_s=5.0)
    if np.count_nonzero(sel) < 8:
        return nan()
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
        return nan()
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
    sel = flight_window(data, window, after_liftoff_s=5.0)
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
    pred = predicted_tilt_rad(cols, gravity_of(data), force_enu=(fx, fy))
    with np.errstate(invalid="ignore", divide="ignore"):
        ux, uy = -fx / fmag, -fy / fmag  # upwind direction: against the aerodynamic force
    along = np.arctan2(zb[:, 0] * ux + zb[:, 1] * uy, zb[:, 2])
    wx, wy = data.column("wind_enu_x_mps")[idx], data.column("wind_enu_y_mps")[idx]
    tt = data.t[idx]
    lean = smooth(zb[:, 0], tt, 1.0) * wx + smooth(zb[:, 1], tt, 1.0) * wy  # 1 s average: attitude jitter out
    strong = (np.hypot(wx, wy) > 0.5) & (pred >= math.radians(1.5))
    sign = np.where(strong, np.sign(-lean), np.nan)
    ok = fmag > 1e-6
    return along[ok], pred[ok], sign


@metric("tilt_into_wind_ratio", "1")
def tilt_into_wind_ratio(data: RunData, window: Window) -> float:
    """Mean tilt towards the upwind side / mean atan(F_h / (m g)); F_h = horizontal wind drag of the
    links plus the rotors' H-force (1 = the thesis' steady tilt; negative = leaning downwind). NaN
    (null) when the mean horizontal wind is below 0.5 m/s: no wind, nothing to tilt into."""
    sel = flight_window(data, window, after_liftoff_s=5.0)
    if not sel.any():
        return nan()
    wind = np.hypot(data.column("wind_enu_x_mps")[sel], data.column("wind_enu_y_mps")[sel])
    if not float(np.mean(wind)) >= MIN_WIND_MPS:
        return nan()
    along, pred, _ = _tilt_terms(data, window)
    if along.size == 0 or np.mean(pred) <= 0:
        return nan()
    return float(np.mean(along) / np.mean(pred))


@metric("tilt_into_wind_fraction", "1")
def tilt_into_wind_fraction(data: RunData, window: Window) -> float:
    """Fraction of the gusty samples (predicted steady tilt >= 1.5 deg) where the body z axis (1 s average)
    leans upwind (1 = always); below that the tilt is dominated by the position loop, not the wind."""
    _, _, sign = _tilt_terms(data, window)
    s = sign[np.isfinite(sign)]
    return float(np.mean(s > 0)) if s.size else nan()


@metric("tilt_mean_deg", "deg")
def tilt_mean_deg(data: RunData, window: Window) -> float:
    """Mean measured tilt towards the upwind side, deg."""
    along, _, _ = _tilt_terms(data, window)
    return float(np.degrees(np.mean(along))) if along.size else nan()


@metric("tilt_pred_deg", "deg")
def tilt_pred_deg(data: RunData, window: Window) -> float:
    """Mean predicted steady tilt atan(F_h / (m g)), deg."""
    _, pred, _ = _tilt_terms(data, window)
    return float(np.degrees(np.mean(pred))) if pred.size else nan()
