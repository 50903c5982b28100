"""Figure 16: the flown path over the terrain, from above: hillshade, contours, vine rows and hedges, wind arrows,
geofence, the path coloured by its height above the terrain (the field map beside the figures is the same view
to zoom into)."""

from __future__ import annotations

from typing import Any

import numpy as np

from vinecli.missions.metrics import airborne_mask
from vinecli.report.budget_plots import draw_hedges
from vinecli.report.figure_base import (
    C_FAIL,
    DPI,
    PlotData,
    png_bytes,
    set_title,
)
from vinecli.report.figure_marks import need


def fig16_path(data: PlotData) -> bytes:
    """Flown path over the terrain, top view (hillshade + contours, vine rows, wind arrows, geofence), the path
    coloured by its height above the terrain and thinned to what the figure's pixels show."""
    need(data, "pos_enu_x_m", "pos_enu_y_m", "pos_enu_z_m", what="position")
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
    plo, phi = np.nanmin(np.column_stack([x, y]), axis=0), np.nanmax(np.column_stack([x, y]), axis=0)
    margin = max(8.0, 0.15 * float(np.max(phi - plo)))
    vlo, vhi = np.maximum(plo - margin, lo), np.minimum(phi + margin, hi)
    fig, ax, cax, w_px = _layout(float(vhi[0] - vlo[0]), float(vhi[1] - vlo[1]))
    pv = data.preview
    if pv is not None:
        ext = (pv["x"][0], pv["x"][-1], pv["y"][0], pv["y"][-1])
        dx = abs(pv["x"][1] - pv["x"][0]) if pv["x"].size > 1 else 1.0
        dy = abs(pv["y"][1] - pv["y"][0]) if pv["y"].size > 1 else 1.0
        shade = LightSource(azdeg=315, altdeg=45).hillshade(pv["z"], vert_exag=3.0, dx=dx, dy=dy)
        ax.imshow(shade, extent=ext, origin="lower", cmap="gray", alpha=0.55, aspect="equal", zorder=0,
                  interpolation="bilinear")  # the preview's cells (0.2-0.5 m) would show as blocks zoomed in
        # contours of the smoothed surface (a DSM's canopy would otherwise turn them into noise)
        zs = gaussian_smooth(pv["z"], sigma=max(1.0, min(pv["z"].shape) / 40.0))
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
    k = _thinned(x, y, agl, 0.5 * float(vhi[0] - vlo[0]) / w_px)
    seg = np.stack([np.column_stack([x[k][:-1], y[k][:-1]]), np.column_stack([x[k][1:], y[k][1:]])], axis=1)
    lc = LineCollection(seg, cmap="plasma", linewidths=2.6, zorder=6)
    lc.set_array(agl[k][:-1])
    ax.add_collection(lc)
    fig.colorbar(lc, cax=cax, label="path height above terrain, m")
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
    # zoomed on the flown path
    ax.set_xlim(vlo[0], vhi[0])
    ax.set_ylim(vlo[1], vhi[1])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("east x, m (ENU)")
    ax.set_ylabel("north y, m (ENU)")
    fig.legend(*ax.get_legend_handles_labels(), fontsize=7, loc="lower left", bbox_to_anchor=(0.01, 0.0), ncol=4,
               frameon=False)
    set_title(fig, data, "Fig. 16  Flown path over the terrain")
    return png_bytes(fig, colour_scale=True)


#: fig. 16's map: its height (inches) unless the view is wide, its width at most
MAP_H_IN, MAP_MAX_W_IN = 4.8, 9.0


def _layout(w_m: float, h_m: float) -> tuple[Any, Any, Any, float]:
    """(figure, map axes, colour-bar axes, the map's width in pixels) for a view of ``w_m`` x ``h_m`` metres: the
    figure takes the view's shape."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    wm = min(max(MAP_H_IN * w_m / max(h_m, 1e-9), 3.0), MAP_MAX_W_IN)
    hm = min(MAP_H_IN, wm * h_m / max(w_m, 1e-9)) if wm >= MAP_MAX_W_IN else MAP_H_IN
    w, h = wm + 2.4, hm + 1.6
    fig = Figure(figsize=(max(w, 6.0), h), dpi=DPI)
    w = max(w, 6.0)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.9 / w, 0.95 / h, wm / w, hm / h))
    cax = fig.add_axes(((1.1 + wm) / w, 0.95 / h, 0.15 / w, hm / h))
    return fig, ax, cax, wm * DPI


def gaussian_smooth(z: np.ndarray, sigma: float) -> np.ndarray:
    """``z`` (2-D) smoothed by a Gaussian of ``sigma`` cells, edges extended by their nearest value, the kernel cut
    at 4 sigma: scipy.ndimage's ``gaussian_filter(z, sigma, mode="nearest")``, in numpy (a preview is 129 cells
    on a side at most; importing scipy.ndimage for it cost a cold report 0.13 s)."""
    r = int(4.0 * sigma + 0.5)
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k /= k.sum()
    out = np.asarray(z, dtype=float)
    for axis in (0, 1):
        n = out.shape[axis]
        pad = [(0, 0), (0, 0)]
        pad[axis] = (r, r)
        p = np.pad(out, pad, mode="edge")
        acc = np.zeros_like(out)
        for i, w in enumerate(k):
            acc += w * np.take(p, np.arange(i, i + n), axis=axis)
        out = acc
    return out


def _thinned(x: np.ndarray, y: np.ndarray, h: np.ndarray, tol: float) -> np.ndarray:
    """Indices of the samples to draw: the first, every one at least ``tol`` (m, half a pixel) from the last kept in
    the plane or 5 cm in height from it, and the last."""
    keep = [0]
    lx, ly, lh = x[0], y[0], h[0]
    for i in range(1, x.size - 1):
        if abs(x[i] - lx) >= tol or abs(y[i] - ly) >= tol or abs(h[i] - lh) >= 0.05:
            keep.append(i)
            lx, ly, lh = x[i], y[i], h[i]
    if x.size > 1:
        keep.append(x.size - 1)
    return np.asarray(keep, dtype=int)
