"""Figures 17-19 (thesis §5.1-5.2): the tank force around lift-off, the drag against the wind and the
velocity, the tank level and liquid mass with the flow command."""

from __future__ import annotations

import numpy as np

from vinecli.report.figure_base import (
    NoData,
    PlotData,
    new_figure,
    png_bytes,
    set_title,
)
from vinecli.report.figure_marks import align_zero, event_lines, has_tank, need, shade_check_windows


def fig17_tank_force(data: PlotData) -> bytes:
    """Tank force along world z split into gravitational and inertial parts around lift-off."""
    need(data, "tank_force_enu_z_n", what="tank force")
    if not has_tank(data):
        raise NoData("no tank (or an empty tank) in this run")
    c, t = data.cols, data.t
    lo = data.liftoff()
    sel = (t >= lo - 3.0) & (t <= lo + 8.0) if lo is not None else np.ones(t.shape, bool)
    fig, axes = new_figure("fig17", 2, 1)
    ax, ax2 = axes[0, 0], axes[1, 0]
    ax.plot(t[sel], c["tank_force_enu_z_n"][sel], color="k", lw=1.6, label="total  m(g − a)")
    if data.has("tank_force_grav_enu_z_n"):
        ax.plot(t[sel], c["tank_force_grav_enu_z_n"][sel], color="#1f77b4", lw=1.2, ls="--", label="gravitational  m g")
    if data.has("tank_force_inertial_enu_z_n"):
        ax.plot(t[sel], c["tank_force_inertial_enu_z_n"][sel], color="#ff7f0e", lw=1.2, label="inertial  −m a")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_ylabel("tank force, world z\n(ENU, up +), N")
    ax.legend(fontsize=7, loc="center right")
    if data.has("acc_enu_z_mps2"):
        ax2.plot(t[sel], c["acc_enu_z_mps2"][sel], color="#ff7f0e", lw=1.0, label="a_z, m/s²")
    if data.has("vel_enu_z_mps"):
        ax2.plot(t[sel], c["vel_enu_z_mps"][sel], color="#2ca02c", lw=1.0, label="v_z, m/s")
    ax2.axhline(0.0, color="0.6", lw=0.6)
    ax2.set_ylabel("vertical motion\n(ENU z)")
    ax2.set_xlabel("time, s")
    ax2.legend(fontsize=7, loc="upper right")
    for a in (ax, ax2):
        event_lines(a, data, ("liftoff",))
        a.grid(alpha=0.3)
    shade_check_windows([ax, ax2], "fig17", data)
    ax2.set_xlim(float(t[sel][0]), float(t[sel][-1]))
    # y limits ignore the first 0.5 s (the vehicle settling on the terrain at spawn can spike the force)
    settle = sel & (t >= float(t[0]) + 0.5)
    if settle.sum() > 10:
        for a, names in ((ax, ("tank_force_enu_z_n", "tank_force_grav_enu_z_n", "tank_force_inertial_enu_z_n")),
                         (ax2, ("acc_enu_z_mps2", "vel_enu_z_mps"))):
            vals = np.concatenate([c[n][settle] for n in names if data.has(n)] or [np.zeros(1)])
            vals = vals[np.isfinite(vals)]
            if vals.size:
                lo_y, hi_y = float(np.min(vals)), float(np.max(vals))
                pad = max(0.5, 0.1 * (hi_y - lo_y))
                a.set_ylim(min(lo_y, 0.0) - pad, max(hi_y, 0.0) + pad)
                if np.nanmax(np.abs(np.concatenate([c[n][sel] for n in names if data.has(n)]))) > max(abs(lo_y), abs(hi_y)) + pad:
                    a.annotate("spawn transient clipped", (0.01, 0.02), xycoords="axes fraction", fontsize=7, color="0.4")
    set_title(fig, data, "Fig. 17  Tank force around lift-off" + ("" if lo is not None else " (no lift-off)"))
    return png_bytes(fig)


# ---------------------------------------------------------------- figure 18
def fig18_drag(data: PlotData) -> bytes:
    """Drag force x, y, z (ENU) with the wind and the drone velocity on the same time axis."""
    need(data, "drag_enu_x_n", "drag_enu_y_n", "drag_enu_z_n", what="drag force")
    c, t = data.cols, data.t
    fig, axes = new_figure("fig18", 3, 1)
    for k, ax_name in enumerate("xyz"):
        ax = axes[k, 0]
        ax.plot(t, c[f"drag_enu_{ax_name}_n"], color="k", lw=1.3, label=f"drag {ax_name}, N")
        ax.set_ylabel(f"drag {ax_name}, N\n(ENU)")
        ax.axhline(0.0, color="0.6", lw=0.6)
        tw = ax.twinx()
        if data.has(f"wind_enu_{ax_name}_mps"):
            tw.plot(t, c[f"wind_enu_{ax_name}_mps"], color="#1f77b4", lw=1.0, label=f"wind {ax_name}, m/s")
        if data.has(f"vel_enu_{ax_name}_mps"):
            tw.plot(t, c[f"vel_enu_{ax_name}_mps"], color="#ff7f0e", lw=1.0, label=f"drone velocity {ax_name}, m/s")
        tw.set_ylabel("m/s (ENU)")
        lines = ax.get_lines()[:1] + tw.get_lines()
        ax.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="upper right")
        ax.grid(alpha=0.3)
        align_zero(ax, tw)
        event_lines(ax, data, ("liftoff", "touchdown"))
    axes[2, 0].set_xlabel("time, s")
    shade_check_windows([axes[k, 0] for k in range(3)], "fig18", data)
    set_title(fig, data, "Fig. 18  Link drag c|v_app|v_app (v_app = wind − velocity) vs wind and velocity")
    return png_bytes(fig)


# ---------------------------------------------------------------- figure 19
def fig19_tank(data: PlotData) -> bytes:
    """Tank level and liquid mass vs time, with the commanded and actual nozzle flow."""
    need(data, "tank_level_l", what="tank level")
    if not has_tank(data) and not data.has("tank_flow_cmd_lps"):
        raise NoData("no tank in this run")
    c, t = data.cols, data.t
    fig, axes = new_figure("fig19", 2, 1)
    ax, ax2 = axes[0, 0], axes[1, 0]
    ax.plot(t, c["tank_level_l"], color="#1f77b4", lw=1.6, label="level, L")
    ax.set_ylabel("tank level, L")
    if data.has("tank_mass_kg"):
        tw = ax.twinx()
        tw.plot(t, c["tank_mass_kg"], color="#8c564b", lw=1.0, ls="--", label="liquid mass, kg")
        tw.set_ylabel("liquid mass, kg")
        lines = ax.get_lines() + tw.get_lines()
        ax.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="upper right")
    if data.has("tank_flow_cmd_lps"):
        ax2.step(t, c["tank_flow_cmd_lps"], where="post", color="k", lw=1.2, label="flow command, L/s")
    if data.has("tank_flow_lps"):
        ax2.plot(t, c["tank_flow_lps"], color="#ff7f0e", lw=1.0, label="actual flow, L/s")
    ax2.set_ylabel("nozzle flow, L/s")
    ax2.set_xlabel("time, s")
    ax2.legend(fontsize=7, loc="upper right")
    for a in (ax, ax2):
        a.grid(alpha=0.3)
        event_lines(a, data, ("liftoff", "tank_empty"))
    shade_check_windows([ax, ax2], "fig19", data)
    set_title(fig, data, "Fig. 19  Tank level and flow")
    return png_bytes(fig)
