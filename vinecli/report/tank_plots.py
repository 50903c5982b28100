"""Figures 17-19 (thesis §5.1-5.2), drawn in the browser (:mod:`~vinecli.report.chart`): the tank force around
lift-off, the drag against the wind and the velocity, the tank level and liquid mass with the flow command."""

from __future__ import annotations

import numpy as np

from vinecli.report.chart import Chart, Panel, Series, chart_bytes, limits, zero_aligned
from vinecli.report.figure_base import NoData, PlotData, title_text
from vinecli.report.figure_marks import check_windows, event_marks, has_tank, need


def _settled_limits(c: dict[str, np.ndarray], names: tuple[str, ...], sel: np.ndarray, settle: np.ndarray
                    ) -> tuple[tuple[float, float] | None, bool]:
    """(y range of the columns ``names`` over ``settle`` with 0 in it, whether samples of ``sel`` lie beyond it)."""
    if settle.sum() <= 10:
        return None, False
    vals = np.concatenate([c[n][settle] for n in names if n in c] or [np.zeros(1)])
    vals = vals[np.isfinite(vals)]
    if not vals.size:
        return None, False
    lo, hi = float(vals.min()), float(vals.max())
    pad = max(0.5, 0.1 * (hi - lo))
    lim = (min(lo, 0.0) - pad, max(hi, 0.0) + pad)
    every = np.concatenate([c[n][sel] for n in names if n in c])
    return lim, bool(np.nanmax(np.abs(every)) > max(abs(lo), abs(hi)) + pad)


def fig17_tank_force(data: PlotData) -> bytes:
    """Tank force along world z split into gravitational and inertial parts around lift-off."""
    need(data, "tank_force_enu_z_n", what="tank force")
    if not has_tank(data):
        raise NoData("no tank (or an empty tank) in this run")
    c, t = data.cols, data.t
    lo = data.liftoff()
    sel = (t >= lo - 3.0) & (t <= lo + 8.0) if lo is not None else np.ones(t.shape, bool)
    force = [Series("total  m(g − a)", c["tank_force_enu_z_n"][sel], "#000000", 1.6)]
    if data.has("tank_force_grav_enu_z_n"):
        force.append(Series("gravitational  m g", c["tank_force_grav_enu_z_n"][sel], "#1f77b4", 1.2, (6, 4)))
    if data.has("tank_force_inertial_enu_z_n"):
        force.append(Series("inertial  −m a", c["tank_force_inertial_enu_z_n"][sel], "#ff7f0e", 1.2))
    motion = [Series(lab, c[n][sel], col) for n, lab, col in (("acc_enu_z_mps2", "a_z, m/s²", "#ff7f0e"),
                                                              ("vel_enu_z_mps", "v_z, m/s", "#2ca02c"))
              if data.has(n)]
    # y ranges leave out the first 0.5 s (the vehicle settling on the terrain at spawn can spike the force)
    settle = sel & (t >= float(t[0]) + 0.5)
    f_lim, f_clip = _settled_limits(c, ("tank_force_enu_z_n", "tank_force_grav_enu_z_n",
                                        "tank_force_inertial_enu_z_n"), sel, settle)
    m_lim, m_clip = _settled_limits(c, ("acc_enu_z_mps2", "vel_enu_z_mps"), sel, settle)
    what = "Fig. 17  Tank force around lift-off" + ("" if lo is not None else " (no lift-off)")
    return chart_bytes(Chart(
        title_text(data, what), t[sel],
        [Panel("tank force z, N (up +)", force, ylim=f_lim, zero=True),
         Panel("vertical motion (ENU z)", motion, ylim=m_lim, zero=True)],
        events=event_marks(data, ("liftoff",)), windows=check_windows("fig17", data),
        notes=["spawn transient clipped (the first 0.5 s)"] if f_clip or m_clip else []))


# ---------------------------------------------------------------- figure 18
def fig18_drag(data: PlotData) -> bytes:
    """Drag force x, y, z (ENU) with the wind and the drone velocity on the same time axis."""
    need(data, "drag_enu_x_n", "drag_enu_y_n", "drag_enu_z_n", what="drag force")
    c, t = data.cols, data.t
    panels = []
    for a in "xyz":
        right = [Series(lab, c[n], col) for n, lab, col in ((f"wind_enu_{a}_mps", f"wind {a}, m/s", "#1f77b4"),
                                                            (f"vel_enu_{a}_mps", f"drone velocity {a}, m/s",
                                                             "#ff7f0e")) if data.has(n)]
        drag = c[f"drag_enu_{a}_n"]
        lim, lim2 = limits(drag, zero=True), limits(*(s.y for s in right), zero=True)
        if lim is not None and lim2 is not None:
            lim, lim2 = zero_aligned(lim, lim2)
        panels.append(Panel(f"drag {a}, N (ENU)", [Series(f"drag {a}, N", drag, "#000000", 1.3),
                                                   *(Series(s.label, s.y, s.color, right=True) for s in right)],
                            y2label="m/s (ENU)", ylim=lim, y2lim=lim2, zero=True, height=180))
    return chart_bytes(Chart(
        title_text(data, "Fig. 18  Link drag c|v_app|v_app (v_app = wind − velocity) vs wind and velocity"), t,
        panels, events=event_marks(data, ("liftoff", "touchdown")), windows=check_windows("fig18", data)))


# ---------------------------------------------------------------- figure 19
def fig19_tank(data: PlotData) -> bytes:
    """Tank level and liquid mass vs time, with the commanded and actual nozzle flow."""
    need(data, "tank_level_l", what="tank level")
    if not has_tank(data) and not data.has("tank_flow_cmd_lps"):
        raise NoData("no tank in this run")
    c, t = data.cols, data.t
    level = [Series("level, L", c["tank_level_l"], "#1f77b4", 1.6)]
    if data.has("tank_mass_kg"):
        level.append(Series("liquid mass, kg", c["tank_mass_kg"], "#8c564b", 1.0, (6, 4), right=True))
    flow = []
    if data.has("tank_flow_cmd_lps"):
        flow.append(Series("flow command, L/s", c["tank_flow_cmd_lps"], "#000000", 1.2, step=True))
    if data.has("tank_flow_lps"):
        flow.append(Series("actual flow, L/s", c["tank_flow_lps"], "#ff7f0e", 1.0))
    return chart_bytes(Chart(
        title_text(data, "Fig. 19  Tank level and flow"), t,
        [Panel("tank level, L", level, y2label="liquid mass, kg" if len(level) > 1 else ""),
         Panel("nozzle flow, L/s", flow)],
        events=event_marks(data, ("liftoff", "tank_empty")), windows=check_windows("fig19", data)))
