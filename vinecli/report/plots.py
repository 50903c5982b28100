"""The thesis §5 figures (16-21) and the battery / sorties figure (22) for one run, as PNG bytes.

matplotlib object API only (:class:`matplotlib.figure.Figure` + ``FigureCanvasAgg``, no pyplot
state). Each ``figNN_*`` function takes a :class:`PlotData` and returns PNG bytes, or raises
:class:`NoData` with a note when the run has nothing to show (e.g. no tank). World frame ENU
(x east, y north, z up), body FLU, SI units; check windows are shaded (green passed, red failed)
on the figures whose quantities they test.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.missions.metrics import airborne_mask, predicted_tilt_rad
from vinecli.report.budget_plots import draw_hedges, fig25_budget
from vinecli.report.deposition_plots import fig23_deposition, fig24_row_coverage
from vinecli.report.figure_base import (
    C_FAIL,
    C_OK,
    DPI,
    SIZES,
    NoData,
    PlotData,
    columns_needed,
    new_figure,
    png_bytes,
    set_title,
)

log = logging.getLogger(__name__)

def _align_zero(ax: Any, tw: Any) -> None:
    """Make y = 0 sit at the same height on an axis and its twin (so signs can be compared)."""
    (a0, a1), (b0, b1) = ax.get_ylim(), tw.get_ylim()
    if not (a0 < 0 < a1 or b0 < 0 < b1):
        a0, b0 = min(a0, 0.0), min(b0, 0.0)
    # fraction of the axis below zero: use the larger of the two for both
    fa = -a0 / (a1 - a0) if a1 > a0 else 0.5
    fb = -b0 / (b1 - b0) if b1 > b0 else 0.5
    f = min(max(fa, fb, 0.05), 0.95)
    ax.set_ylim(-f / (1 - f) * max(a1, 1e-12) if a1 > 0 else a0, max(a1, 1e-12) if a1 > 0 else -a0 * (1 - f) / f)
    tw.set_ylim(-f / (1 - f) * max(b1, 1e-12) if b1 > 0 else b0, max(b1, 1e-12) if b1 > 0 else -b0 * (1 - f) / f)


def _vlines(ax: Any, data: PlotData, kinds: Sequence[str] = ("liftoff", "touchdown", "tank_empty")) -> None:
    styles = {"liftoff": ("#1f77b4", "lift-off"), "touchdown": ("#7f7f7f", "touchdown"),
              "tank_empty": ("#9467bd", "tank empty"), "battery_swap": ("#2e7d32", "battery swap"),
              "refill": ("#0d47a1", "refill / service")}
    every = ("battery_swap", "refill")  # one line per service of a refill job, labelled once
    lo = data.liftoff()
    drawn: list[float] = []
    for k in kinds:
        if k == "liftoff":
            times = [lo] if lo is not None else []
        else:
            times = data.event_times(k) if k in every else data.event_times(k)[-1:]
        times = [te for te in times if all(abs(te - d) > 0.05 for d in drawn)]  # a swap during a refill: once
        drawn += times
        for i, te in enumerate(times):
            color, label = styles[k]
            ax.axvline(te, color=color, ls=":", lw=1.2)
            if i == 0:
                ax.annotate(label, (te, 1.0), xycoords=("data", "axes fraction"), xytext=(2, -10),
                            textcoords="offset points", fontsize=7, color=color)


#: check quantities each figure shows (substring match on the check's quantity)
CHECK_TOPICS: dict[str, tuple[str, ...]] = {
    "fig17": ("tank_force", "liftoff_force", "climb_tank", "climb_duration", "liquid_weight"),
    "fig18": ("drag",),
    "fig19": ("tank_level", "tank_flow", "drain", "tank_mass"),
    "fig20": ("rotor", "hover", "mass"),
    "fig21": ("tilt", "wind", "hpos", "roll", "pitch", "yaw"),
    "fig22": ("battery", "energy", "sortie", "soc"),
}


def check_spans(name: str, checks: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Checks with a time window whose quantity belongs to figure ``name``."""
    topics = CHECK_TOPICS.get(name, ())
    out = []
    for c in checks:
        w = c.get("window")
        if isinstance(w, (list, tuple)) and len(w) == 2 and any(k in str(c.get("quantity", "")) for k in topics):
            out.append(c)
    return out


def _spans(axes: Sequence[Any], name: str, data: PlotData) -> None:
    """Shade each distinct check window once (red if any of its checks failed), labelled with the check names."""
    groups: dict[tuple[float, float], list[dict[str, Any]]] = {}
    for c in check_spans(name, data.summary.get("checks") or []):
        groups.setdefault((float(c["window"][0]), float(c["window"][1])), []).append(c)
    for i, ((t0, t1), cs) in enumerate(groups.items()):
        ok = all(c.get("passed") for c in cs)
        color = C_OK if ok else C_FAIL
        for j, ax in enumerate(axes):
            ax.axvspan(t0, t1, color=color, alpha=0.10, lw=0)
            if j == 0:
                label = ", ".join(f"{c['name']} ({'pass' if c.get('passed') else 'FAIL'})" for c in cs)
                label = label if len(label) <= 90 else label[:88] + "…"
                ax.annotate(f"checks: {label}", (t0, 0.0), xycoords=("data", "axes fraction"),
                            xytext=(3, 3 + 10 * i), textcoords="offset points", fontsize=7, color=color)


def _need(data: PlotData, *names: str, what: str) -> None:
    missing = [n for n in names if not data.has(n)]
    if missing:
        raise NoData(f"no {what} in this run (no finite samples of {', '.join(missing)})")


def _has_tank(data: PlotData) -> bool:
    return data.has("tank_mass_kg") and float(np.nanmax(data.cols["tank_mass_kg"])) > 0.0


# ---------------------------------------------------------------- figure 16
def fig16_path(data: PlotData) -> bytes:
    """Flown path over the terrain: top view (hillshade + contours, vine rows, wind arrows, geofence) and 3D view."""
    _need(data, "pos_enu_x_m", "pos_enu_y_m", "pos_enu_z_m", what="position")
    from matplotlib.collections import LineCollection
    from matplotlib.colors import LightSource

    c = data.cols
    x, y, z = c["pos_enu_x_m"], c["pos_enu_y_m"], c["pos_enu_z_m"]
    world = data.summary.get("world") or {}
    rows = world.get("rows_enu") or []
    fence = (world.get("geofence") or {}).get("polygon_enu") or []
    pts = [np.column_stack([x, y])] + [np.asarray(r, float) for r in rows if len(r)]
    if len(fence) >= 3:
        pts.append(np.asarray(fence, float))
    allp = np.vstack(pts)
    lo, hi = np.nanmin(allp, axis=0) - 4.0, np.nanmax(allp, axis=0) + 4.0
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=SIZES["fig16"], dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.05, 0.15, 0.47, 0.74))
    ax3 = fig.add_axes((0.56, 0.04, 0.42, 0.86), projection="3d")
    pv = data.preview
    if pv is not None:
        ext = (pv["x"][0], pv["x"][-1], pv["y"][0], pv["y"][-1])
        dx = abs(pv["x"][1] - pv["x"][0]) if pv["x"].size > 1 else 1.0
        dy = abs(pv["y"][1] - pv["y"][0]) if pv["y"].size > 1 else 1.0
        shade = LightSource(azdeg=315, altdeg=45).hillshade(pv["z"], vert_exag=3.0, dx=dx, dy=dy)
        ax.imshow(shade, extent=ext, origin="lower", cmap="gray", alpha=0.55, aspect="equal", zorder=0)
        from scipy.ndimage import gaussian_filter

        # contours of the smoothed surface (a DSM's canopy would otherwise turn them into noise)
        zs = gaussian_filter(pv["z"], sigma=max(1.0, min(pv["z"].shape) / 40.0), mode="nearest")
        cs = ax.contour(pv["x"], pv["y"], zs, levels=8, colors="#8c6d31", linewidths=0.6, zorder=1)
        ax.clabel(cs, fontsize=6, fmt="%.1f m")
    for i, r in enumerate(rows):
        r = np.asarray(r, float)
        if r.ndim == 2 and len(r) >= 2:
            ax.plot(r[:, 0], r[:, 1], color="#2e7d32", lw=1.0, alpha=0.7, zorder=2, label="vine rows" if i == 0 else None)
    draw_hedges(ax, data, rows)
    if len(fence) >= 3:
        f = np.asarray(fence + fence[:1], float)
        ax.plot(f[:, 0], f[:, 1], color=C_FAIL, ls="--", lw=1.2, zorder=2, label="geofence")
    agl = c["height_agl_m"] if data.has("height_agl_m") else z - np.nanmin(z)
    seg = np.stack([np.column_stack([x[:-1], y[:-1]]), np.column_stack([x[1:], y[1:]])], axis=1)
    lc = LineCollection(seg, cmap="plasma", linewidths=2.6, zorder=6)
    lc.set_array(agl[:-1])
    ax.add_collection(lc)
    fig.colorbar(lc, ax=ax, fraction=0.05, pad=0.02, label="path height above terrain, m")
    bps = [s["breakpoint_enu"] for s in data.summary.get("sorties") or [] if s.get("breakpoint_enu")]
    if bps:  # where each sortie of a refill job stopped spraying (and the next one resumed)
        b = np.asarray(bps, float)
        ax.plot(b[:, 0], b[:, 1], marker="X", color="#0d47a1", ms=8, mec="w", ls="", zorder=7,
                label=f"sortie breakpoints ({len(bps) + 1} sorties)")
        for i, (bx, by) in enumerate(b[:, :2], start=1):
            ax.annotate(str(i), (bx, by), xytext=(4, 3), textcoords="offset points", fontsize=7, color="#0d47a1",
                        zorder=7)
    ax.plot(x[0], y[0], marker="^", color="k", ms=7, ls="", zorder=4, label="start")
    ax.plot(x[-1], y[-1], marker="s", color="k", ms=5, ls="", zorder=4, label="end")
    if float(np.max(np.nanmax(np.column_stack([x, y]), axis=0) - np.nanmin(np.column_stack([x, y]), axis=0))) < 3.0:
        # hover-like flight: the drift is invisible at field scale, show it in an inset
        air = airborne_mask(c)
        ins = ax.inset_axes((0.6, 0.5, 0.38, 0.38))
        ins.plot(x[air], y[air], color="#d62728", lw=0.8)
        if data.has("sp_pos_enu_x_m", "sp_pos_enu_y_m"):
            ins.plot(c["sp_pos_enu_x_m"][air], c["sp_pos_enu_y_m"][air], marker="+", color="k", ms=8, ls="",
                     label="setpoint")
        ins.set_aspect("equal", adjustable="datalim")
        ins.tick_params(labelsize=6)
        ins.set_title("airborne path detail, m (ENU)", fontsize=7)
        ins.grid(alpha=0.3)
    if data.has("wind_enu_x_mps", "wind_enu_y_mps"):
        wx, wy = c["wind_enu_x_mps"], c["wind_enu_y_mps"]
        air = airborne_mask(c)
        idx = np.flatnonzero(air) if air.any() else np.arange(x.size)
        k = idx[np.linspace(0, idx.size - 1, min(14, idx.size)).astype(int)]
        if np.nanmax(np.hypot(wx, wy)) > 0.05:
            q = ax.quiver(x[k], y[k], wx[k], wy[k], color="#1565c0", angles="xy", scale_units="inches", scale=6.0,
                          width=0.004, zorder=5)
            ax.quiverkey(q, 0.97, 1.03, 3.0, "wind 3 m/s", labelpos="W", fontproperties={"size": 7})
        else:
            ax.text(0.02, 0.97, "no horizontal wind", transform=ax.transAxes, fontsize=7, va="top")
    # top view: zoomed on the flown path (the 3D view keeps the whole field for context)
    plo, phi = np.nanmin(np.column_stack([x, y]), axis=0), np.nanmax(np.column_stack([x, y]), axis=0)
    margin = max(8.0, 0.15 * float(np.max(phi - plo)))
    vlo, vhi = np.maximum(plo - margin, lo), np.minimum(phi + margin, hi)
    ax.set_xlim(vlo[0], vhi[0])
    ax.set_ylim(vlo[1], vhi[1])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("east x, m (ENU)")
    ax.set_ylabel("north y, m (ENU)")
    ax.set_title("top view", fontsize=9, loc="left")
    fig.legend(*ax.get_legend_handles_labels(), fontsize=7, loc="lower left", bbox_to_anchor=(0.01, 0.0), ncol=4,
               frameon=False)
    # 3D view: terrain surface (downsampled) and the path
    if pv is not None:
        sx = max(1, pv["x"].size // 40)
        sy = max(1, pv["y"].size // 40)
        xx, yy = np.meshgrid(pv["x"][::sx], pv["y"][::sy])
        zz = pv["z"][::sy, ::sx]
        keep = (xx >= lo[0]) & (xx <= hi[0]) & (yy >= lo[1]) & (yy <= hi[1])
        zz = np.where(keep, zz, np.nan)
        ax3.plot_surface(xx, yy, zz, cmap="terrain", alpha=0.45, linewidth=0, antialiased=False, rstride=1, cstride=1)
    ax3.computed_zorder = False  # draw the path over the terrain surface
    ax3.plot(x, y, z, color="#d62728", lw=1.8, zorder=10, label="path (CoM)")
    ax3.set_xlabel("east x, m")
    ax3.set_ylabel("north y, m")
    ax3.set_zlabel("up z, m (ENU)")
    ax3.set_xlim(lo[0], hi[0])
    ax3.set_ylim(lo[1], hi[1])
    ax3.view_init(elev=28, azim=-60)
    ax3.set_title("3D view", fontsize=9)
    ax3.tick_params(labelsize=7)
    set_title(fig, data, "Fig. 16  Flown path over the terrain")
    return png_bytes(fig)


# ---------------------------------------------------------------- figure 17
def fig17_tank_force(data: PlotData) -> bytes:
    """Tank force along world z split into gravitational and inertial parts around lift-off."""
    _need(data, "tank_force_enu_z_n", what="tank force")
    if not _has_tank(data):
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
        _vlines(a, data, ("liftoff",))
        a.grid(alpha=0.3)
    _spans([ax, ax2], "fig17", data)
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
    _need(data, "drag_enu_x_n", "drag_enu_y_n", "drag_enu_z_n", what="drag force")
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
        _align_zero(ax, tw)
        _vlines(ax, data, ("liftoff", "touchdown"))
    axes[2, 0].set_xlabel("time, s")
    _spans([axes[k, 0] for k in range(3)], "fig18", data)
    set_title(fig, data, "Fig. 18  Link drag c|v_app|v_app (v_app = wind − velocity) vs wind and velocity")
    return png_bytes(fig)


# ---------------------------------------------------------------- figure 19
def fig19_tank(data: PlotData) -> bytes:
    """Tank level and liquid mass vs time, with the commanded and actual nozzle flow."""
    _need(data, "tank_level_l", what="tank level")
    if not _has_tank(data) and not data.has("tank_flow_cmd_lps"):
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
        _vlines(a, data, ("liftoff", "tank_empty"))
    _spans([ax, ax2], "fig19", data)
    set_title(fig, data, "Fig. 19  Tank level and flow")
    return png_bytes(fig)


# ---------------------------------------------------------------- figure 20
def fig20_rotors(data: PlotData) -> bytes:
    """Rotor speeds against what drives them: total (tank) mass and the wind."""
    rotors = data.rotors()
    if not rotors:
        raise NoData("no rotor speeds in this run")
    c, t = data.cols, data.t
    fig, axes = new_figure("fig20", 3, 1)
    ax, axm, axw = axes[0, 0], axes[1, 0], axes[2, 0]
    for i, r in enumerate(rotors):
        ax.plot(t, c[r], lw=0.7, alpha=0.6, label=f"rotor {i + 1}")
    mean = np.mean([c[r] for r in rotors], axis=0)
    ax.plot(t, mean, color="0.35", lw=0.8, label="mean")
    if t.size > 3:
        dt = float(np.median(np.diff(t)))
        k = max(1, int(round(2.0 / dt))) if dt > 0 else 1
        if t.size > 3 * k:  # centred average, normalised at the edges
            box = np.ones(k)
            avg = np.convolve(mean, box, mode="same") / np.convolve(np.ones_like(mean), box, mode="same")
            ax.plot(t, avg, color="k", lw=1.8, label="mean, 2 s average")
    air = airborne_mask(c)
    if air.any():
        ymin, ymax = np.nanpercentile(mean[air], [1, 99])
        pad = max(20.0, 0.25 * (ymax - ymin))
        ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_ylabel("rotor speed, rad/s")
    ax.legend(fontsize=7, ncol=min(5, len(rotors) + 1), loc="upper right")
    if data.has("total_mass_kg"):
        axm.plot(t, c["total_mass_kg"], color="#8c564b", lw=1.4, label="total mass, kg")
    if data.has("tank_mass_kg"):
        tw = axm.twinx()
        tw.plot(t, c["tank_mass_kg"], color="#1f77b4", lw=1.0, ls="--", label="tank liquid, kg")
        tw.set_ylabel("tank liquid, kg")
        lines = axm.get_lines()[:1] + tw.get_lines()
        axm.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="upper right")
    axm.set_ylabel("total mass, kg")
    if data.has("wind_enu_x_mps", "wind_enu_y_mps"):
        axw.plot(t, np.hypot(c["wind_enu_x_mps"], c["wind_enu_y_mps"]), color="#1f77b4", lw=1.2,
                 label="horizontal wind speed, m/s")
        axw.legend(fontsize=7, loc="upper right")
    axw.set_ylabel("wind, m/s (ENU)")
    axw.set_xlabel("time, s")
    for a in (ax, axm, axw):
        a.grid(alpha=0.3)
        _vlines(a, data)
    _spans([ax, axm, axw], "fig20", data)
    set_title(fig, data, "Fig. 20  Rotor speeds vs mass and wind (hover: w ∝ √m)")
    return png_bytes(fig)


# ---------------------------------------------------------------- figure 21
def _predicted_tilt_deg(data: PlotData) -> np.ndarray | None:
    """The predicted steady tilt (:func:`vinecli.missions.metrics.predicted_tilt_rad`) in deg, with the rotors'
    H-force when the run recorded it and the run's gravity; None without drag or mass."""
    if not data.has("drag_enu_x_n", "drag_enu_y_n", "total_mass_kg"):
        return None
    c = data.cols
    cols = c if data.has("rotor_drag_flu_x_n", "quat_w") else \
        {k: c[k] for k in ("drag_enu_x_n", "drag_enu_y_n", "total_mass_kg")}
    return np.degrees(predicted_tilt_rad(cols, data.gravity))


def fig21_attitude(data: PlotData) -> bytes:
    """Roll/pitch (and yaw) vs the wind: the vehicle tilts into the gust."""
    _need(data, "roll_rad", "pitch_rad", what="attitude")
    c, t = data.cols, data.t
    fig, axes = new_figure("fig21", 3, 1)
    ax, axy, axw = axes[0, 0], axes[1, 0], axes[2, 0]
    ax.plot(t, np.degrees(c["roll_rad"]), color="#1f77b4", lw=1.0, label="roll")
    ax.plot(t, np.degrees(c["pitch_rad"]), color="#ff7f0e", lw=1.0, label="pitch")
    if data.has("tilt_rad"):
        ax.plot(t, np.degrees(c["tilt_rad"]), color="k", lw=1.2, label="tilt |z_body ∠ up|")
    pred = _predicted_tilt_deg(data)
    if pred is not None:
        air = airborne_mask(c)
        ax.plot(t, np.where(air, pred, np.nan), color="#9467bd", lw=1.0, ls="--",
                label="predicted tilt atan(F_h / m g)")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_ylabel("angle, deg\n(Z-Y-X, ENU/FLU)")
    ax.legend(fontsize=7, ncol=2, loc="upper right")
    if data.has("yaw_rad"):
        axy.plot(t, np.degrees(np.unwrap(c["yaw_rad"])), color="#2ca02c", lw=1.0, label="yaw (from east, CCW)")
        axy.legend(fontsize=7, loc="upper right")
    axy.set_ylabel("yaw, deg")
    if data.has("wind_enu_x_mps", "wind_enu_y_mps"):
        axw.plot(t, c["wind_enu_x_mps"], color="#1f77b4", lw=1.0, label="wind east x")
        axw.plot(t, c["wind_enu_y_mps"], color="#d62728", lw=1.0, label="wind north y")
        axw.legend(fontsize=7, loc="upper right")
    axw.set_ylabel("wind, m/s (ENU)")
    axw.set_xlabel("time, s")
    for a in (ax, axy, axw):
        a.grid(alpha=0.3)
        _vlines(a, data, ("liftoff", "touchdown"))
    _spans([ax, axy, axw], "fig21", data)
    set_title(fig, data, "Fig. 21  Attitude vs wind (tilt into the gust; pitch > 0 = nose down in FLU)")
    return png_bytes(fig)


# ---------------------------------------------------------------- figure 22
def fig22_battery(data: PlotData) -> bytes:
    """Battery voltage and state of charge, electrical power, and the sorties of a refill job."""
    _need(data, "battery_soc", "battery_voltage_v", what="battery")
    c, t = data.cols, data.t
    fig, axes = new_figure("fig22", 2, 1)
    ax, ax2 = axes[0, 0], axes[1, 0]
    ax.plot(t, c["battery_voltage_v"], color="#6a1b9a", lw=1.2, label="terminal voltage, V")
    ax.set_ylabel("voltage, V")
    tw = ax.twinx()
    tw.plot(t, 100.0 * c["battery_soc"], color="#2e7d32", lw=1.6, label="state of charge, %")
    tw.set_ylabel("state of charge, %")
    tw.set_ylim(0.0, 105.0)
    lines = ax.get_lines() + tw.get_lines()
    ax.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="lower left")
    if data.has("power_elec_w"):
        ax2.plot(t, c["power_elec_w"], color="#e65100", lw=0.9, label="electrical power drawn, W")
    if data.has("sortie") and np.nanmax(c["sortie"]) > 1:
        tw2 = ax2.twinx()
        tw2.step(t, c["sortie"], where="post", color="#0d47a1", lw=1.0, label="sortie")
        tw2.set_ylabel("sortie")
        lines = ax2.get_lines() + tw2.get_lines()
        ax2.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="upper right")
    else:
        ax2.legend(fontsize=7, loc="upper right")
    ax2.set_ylabel("power, W")
    ax2.set_xlabel("time, s")
    for a in (ax, ax2):
        a.grid(alpha=0.3)
        _vlines(a, data, ("liftoff", "refill", "battery_swap"))
    e_wh = (data.summary.get("metrics") or {}).get("energy_wh")
    what = "Fig. 22  Battery and sorties" + (f" ({e_wh:.1f} Wh drawn)" if isinstance(e_wh, float) else "")
    set_title(fig, data, what)
    return png_bytes(fig)


#: figure id -> (caption, function)
FIGURES: dict[str, tuple[str, Callable[[PlotData], bytes]]] = {
    "fig16": ("Flown path over the terrain with vine rows, wind arrows and geofence", fig16_path),
    "fig17": ("Tank force along z: gravitational and inertial parts around lift-off", fig17_tank_force),
    "fig18": ("Drag force components x, y, z with the wind and the drone velocity", fig18_drag),
    "fig19": ("Tank level and liquid mass vs time with the flow command", fig19_tank),
    "fig20": ("Rotor speeds against the factors that drive them (mass, wind)", fig20_rotors),
    "fig21": ("Roll, pitch, yaw vs wind: the tilt into the gust", fig21_attitude),
    "fig22": ("Battery voltage, state of charge and power; sorties and battery swaps of a refill job", fig22_battery),
}


FIGURES["fig23"] = ("Spray deposition (L/ha) over the terrain with the rows, the flown path and the fence",
                    fig23_deposition)
FIGURES["fig24"] = ("Coverage along the targeted rows: rate along each row and the share covered", fig24_row_coverage)
FIGURES["fig25"] = ("Where the spray went: canopy, ground in and off the field, airborne, evaporated (per row) "
                    "and the drift curve downwind", fig25_budget)


def load_plot_data(run_dir: str | Path, columns: Sequence[str] | None = None) -> PlotData:
    """Read what the figures need from a (validated) run directory."""
    from vinecli.constants import STANDARD_GRAVITY
    from vinecli.report.loader import load_run
    from vinecli.runs.rundir import world_gravity

    run = load_run(Path(run_dir))
    g = world_gravity(run.summary)
    return PlotData(cols=run.read_columns(columns or columns_needed()), events=run.events(), summary=run.summary,
                    preview=run.preview(), run_dir=Path(run_dir), gravity=STANDARD_GRAVITY if g is None else g)


def render_figures(run_dir: str, only: Sequence[str] | None = None) -> dict[str, dict[str, Any]]:
    """All figures of one run: ``{fig id: {"png": bytes | None, "note": str, "caption": str}}``.

    Top-level and picklable: the report maps it over a process pool.
    """
    data = load_plot_data(run_dir)
    out: dict[str, dict[str, Any]] = {}
    for fid, (caption, fn) in FIGURES.items():
        if only is not None and fid not in only:
            continue
        try:
            out[fid] = {"png": fn(data), "note": "", "caption": caption}
        except NoData as exc:
            out[fid] = {"png": None, "note": str(exc), "caption": caption}
        except (ValueError, IndexError, KeyError, FloatingPointError) as exc:  # data too degenerate to plot
            log.warning("%s: %s not drawn: %s", run_dir, fid, exc)
            out[fid] = {"png": None, "note": f"not drawn: {type(exc).__name__}: {exc}", "caption": caption}
    return out


def png_size(png: bytes) -> tuple[int, int]:
    """(width, height) in pixels from a PNG's IHDR chunk."""
    if png[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    return int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")


def expected_size(fid: str) -> tuple[int, int]:
    w, h = SIZES[fid]
    return int(round(w * DPI)), int(round(h * DPI))


__all__ = ["FIGURES", "NoData", "PlotData", "check_spans", "expected_size", "load_plot_data", "png_size",
           "render_figures"]
