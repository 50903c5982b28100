"""Spraying metrics (thesis §5.2): drain time against the commanded flow, rotor speed following the
mass (hover law), the path on the rows."""

from __future__ import annotations

import math

import numpy as np

from vinecli.geometry import point_polyline_distance
from vinecli.missions.metrics.base import (
    Window,
    airborne,
    event_time_or_none,
    flight_window,
    mean_rotor_speed,
    metric,
    nan,
    reduce_or_nan,
    rms,
    smooth,
    window_mask,
)
from vinecli.missions.rundata import RunData


def _drain(data: RunData, window: Window) -> tuple[float, float]:
    """(measured flow-on time until empty, predicted volume / commanded flow), s."""
    t = data.t
    sel = window_mask(data, window, None)
    cmd = data.column("tank_flow_cmd_lps")
    level = data.column("tank_level_l")
    on = sel & (cmd > 0)
    if not on.any():
        return nan(), nan()
    i0 = int(np.flatnonzero(on)[0])
    t_empty = event_time_or_none(data, "tank_empty")
    if t_empty is None:
        return nan(), nan()
    dt = np.diff(t, append=t[-1])
    before = on & (t < t_empty - 1e-9)
    measured = float(np.sum(dt[before]))
    q = float(np.mean(cmd[before])) if before.any() else nan()
    v0 = float(level[i0 - 1] if i0 > 0 else level[i0])
    return measured, (v0 / q if q > 0 else nan())


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
    return m / p if p and math.isfinite(p) else nan()


@metric("spray_flow_ratio", "1")
def spray_flow_ratio(data: RunData, window: Window) -> float:
    """Delivered / commanded nozzle flow while the flow is commanded on and the tank has liquid (1 = the
    level falls at the commanded rate). Default: whole run."""
    sel = window_mask(data, window, None)
    cmd = data.column("tank_flow_cmd_lps")
    flow = data.column("tank_flow_lps")
    level = data.column("tank_level_l")
    prev_level = np.concatenate([level[:1], level[:-1]])
    on = sel & (cmd > 0) & (prev_level > 1e-9) & (level > 1e-9)
    if not on.any() or cmd[on].sum() <= 0:
        return nan()
    return float(flow[on].sum() / cmd[on].sum())


#: below this mass change (kg) over the window the mass counts as constant (no correlation to speak of)
MIN_MASS_CHANGE_KG = 1e-3


@metric("rotor_mass_correlation", "1")
def rotor_mass_correlation(data: RunData, window: Window) -> float:
    """Pearson correlation of the mean rotor speed (5 s moving average: manoeuvres out) with total mass,
    airborne; NaN (null) when the mass changes by less than 1 g. Default: lift-off +3 s .. touchdown."""
    sel = flight_window(data, window)
    if np.count_nonzero(sel) < 10:
        return nan()
    w = smooth(mean_rotor_speed(data)[sel], data.t[sel], 5.0)
    m = data.column("total_mass_kg")[sel]
    if np.std(w) == 0 or not np.ptp(m) >= MIN_MASS_CHANGE_KG:
        return nan()
    return float(np.corrcoef(w, m)[0, 1])


@metric("hover_w_mass_exponent", "1")
def hover_w_mass_exponent(data: RunData, window: Window) -> float:
    """Slope of log(mean rotor speed, 5 s average) vs log(total mass), airborne (hover law: 0.5)."""
    sel = flight_window(data, window)
    if np.count_nonzero(sel) < 10:
        return nan()
    w = smooth(mean_rotor_speed(data)[sel], data.t[sel], 5.0)
    m = data.column("total_mass_kg")[sel]
    ok = (w > 0) & (m > 0)
    if np.ptp(np.log(m[ok])) < 1e-3:
        return nan()
    return float(np.polyfit(np.log(m[ok]), np.log(w[ok]), 1)[0])


def _cross_track(data: RunData, window: Window) -> np.ndarray:
    rows = list(getattr(data.context, "rows_enu", ()) or ())
    if not rows:
        return np.array([])
    sel = window_mask(data, window, None) & airborne(data) & (data.column("tank_flow_cmd_lps") > 0)
    if not sel.any():
        return np.array([])
    return point_polyline_distance(data.column("pos_enu_x_m")[sel], data.column("pos_enu_y_m")[sel], rows)


@metric("cross_track_rms_m", "m")
def cross_track_rms_m(data: RunData, window: Window) -> float:
    """RMS horizontal distance to the nearest row while spraying (flow commanded, airborne), m."""
    d = _cross_track(data, window)
    return rms(d)


@metric("cross_track_max_m", "m")
def cross_track_max_m(data: RunData, window: Window) -> float:
    """Largest horizontal distance to the nearest row while spraying, m."""
    d = _cross_track(data, window)
    return reduce_or_nan(np.max, d)


@metric("cross_track_p95_m", "m")
def cross_track_p95_m(data: RunData, window: Window) -> float:
    """95th percentile of the distance to the nearest row while spraying, m."""
    d = _cross_track(data, window)
    return reduce_or_nan(lambda a: np.percentile(a, 95), d)
