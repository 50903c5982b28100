"""Take-off metrics (thesis §5.1): the tank force at rest, its jump at lift-off and the steady climb,
the drag against the vertical motion, heights and time in the air."""

from __future__ import annotations

import numpy as np

from vinecli.missions.metrics.base import (
    Window,
    airborne,
    event_time_or_none,
    gravity_of,
    metric,
    nan,
    smooth,
    window_mask,
)
from vinecli.missions.rundata import RunData


@metric("liquid_weight_n", "N")
def liquid_weight_n(data: RunData, window: Window) -> float:
    """Weight of the liquid at the start of the window (default: the run start), N: tank_mass_kg * g."""
    m = data.column("tank_mass_kg")[window_mask(data, window, None)]
    return float(m[0] * gravity_of(data)) if m.size else nan()


@metric("tank_force_rest_ratio", "1")
def tank_force_rest_ratio(data: RunData, window: Window) -> float:
    """Tank force at rest / liquid weight (1 = equal), medians over samples on the ground with |v_z| < 5 mm/s.
    Default window: the 1 s ending 0.3 s before lift-off (the whole run if it never lifts off)."""
    t = data.t
    if window is None:
        tl = event_time_or_none(data, "liftoff")
        t_end = (tl - 0.3) if tl is not None else float(t[-1])
        window = (max(float(t[0]), t_end - 1.0), t_end)
    sel = data.window_mask(window)
    if data.has("on_ground"):
        sel &= data.column("on_ground") > 0.5
    if data.has("vel_enu_z_mps"):
        sel &= np.abs(data.column("vel_enu_z_mps")) < 0.005
    if not sel.any():
        return nan()
    force_down = -data.column("tank_force_enu_z_n")[sel]
    weight = data.column("tank_mass_kg")[sel] * gravity_of(data)
    w = float(np.median(weight))
    return float(np.median(force_down) / w) if w > 0 else nan()


def _around_liftoff(data: RunData, window: Window) -> np.ndarray | None:
    """Mask of ``window``, by default lift-off -1 s .. +2 s; None if there is neither or it is empty."""
    if window is None:
        tl = event_time_or_none(data, "liftoff")
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
        return nan()
    force_down = -data.column("tank_force_enu_z_n")[sel]
    weight = data.column("tank_mass_kg")[sel] * gravity_of(data)
    i = int(np.argmax(force_down))
    return float(force_down[i] / weight[i] - 1.0) if weight[i] > 0 else nan()


@metric("liftoff_force_jump_n", "N")
def liftoff_force_jump_n(data: RunData, window: Window) -> float:
    """Largest |inertial part| of the tank force (z) around lift-off, N. Default window: lift-off -1 s .. +2 s."""
    sel = _around_liftoff(data, window)
    if sel is None:
        return nan()
    if data.has("tank_force_inertial_enu_z_n"):
        f = data.column("tank_force_inertial_enu_z_n")[sel]
    else:
        f = data.column("tank_force_enu_z_n")[sel] + data.column("tank_mass_kg")[sel] * gravity_of(data)
    return float(np.max(np.abs(f)))


def _steady_climb(data: RunData, window: Window, min_vz: float = 0.3, max_az: float = 0.3) -> np.ndarray:
    tl = event_time_or_none(data, "liftoff")
    t = data.t
    default = (tl + 0.5, float(t[-1])) if tl is not None else None
    sel = window_mask(data, window, default) & airborne(data)
    vz = data.column("vel_enu_z_mps")
    az = data.column("acc_enu_z_mps2")
    az_s = smooth(az, t, 0.2)
    return sel & (vz > min_vz) & (np.abs(az_s) < max_az)


@metric("climb_tank_force_ratio", "1")
def climb_tank_force_ratio(data: RunData, window: Window) -> float:
    """Tank force in steady climb (v_z > 0.3 m/s, |a_z| < 0.3 m/s² smoothed over 0.2 s) / liquid weight. Default window: lift-off +0.5 s .. end."""
    sel = _steady_climb(data, window)
    if not sel.any():
        return nan()
    force_down = -data.column("tank_force_enu_z_n")[sel]
    weight = data.column("tank_mass_kg")[sel] * gravity_of(data)
    return float(np.mean(force_down) / np.mean(weight)) if np.mean(weight) > 0 else nan()


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
    sel = window_mask(data, window, None) & airborne(data)
    vz = data.column("vel_enu_z_mps")
    dz = data.column("drag_enu_z_n")
    sel &= np.abs(vz) > min_speed
    if not sel.any():
        return nan()
    return float(np.mean(dz[sel] * vz[sel] < 0))


@metric("altitude_above_home_m", "m")
def altitude_above_home_m(data: RunData, window: Window) -> float:
    """Mean height of the vehicle above its start position (z - z at the first sample) over the window, m. Default: last 1 s."""
    t = data.t
    z = data.column("pos_enu_z_m")
    sel = window_mask(data, window, (float(t[-1]) - 1.0, float(t[-1])))
    return float(np.mean(z[sel]) - z[0]) if sel.any() else nan()


@metric("max_rise_m", "m")
def max_rise_m(data: RunData, window: Window) -> float:
    """Highest point of the vehicle above its height at the window start, m (0 = never rose).
    Default window: 0.5 s after the start (the spawn settle) to the end."""
    t = data.t
    z = data.column("pos_enu_z_m")
    sel = window_mask(data, window, (float(t[0]) + 0.5, float(t[-1])))
    if not sel.any():
        return nan()
    zs = z[sel]
    return float(np.max(zs) - zs[0])


@metric("airborne_time_s", "s")
def airborne_time_s(data: RunData, window: Window) -> float:
    """Time without ground contact (sum of the sample intervals with on_ground = 0), s.
    Default window: 0.5 s after the start (the spawn settle) to the end."""
    t = data.t
    sel = window_mask(data, window, (float(t[0]) + 0.5, float(t[-1])))
    dt = np.diff(t, append=t[-1])
    return float(np.sum(dt[sel & airborne(data)]))
