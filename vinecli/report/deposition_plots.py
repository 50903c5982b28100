"""Deposition figures of a spray run (docs/deposition.md): the L/ha map and the per-row coverage chart.

Read from the run directory's ``deposition.json`` (grid, rows, totals, metrics) and
``deposition.tif`` (rate, L/ha, north-up). World ENU metres, x east, y north. Runs without a
sprayer raise :class:`~vinecli.report.plots.NoData`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.runs.deposition_out import DEPOSITION_JSON

__all__ = ["fig23_deposition", "fig24_row_coverage", "load_deposition"]


def load_deposition(run_dir: Path | None) -> tuple[dict[str, Any], np.ndarray]:
    """(deposition.json, rate L/ha (ny, nx) row 0 SOUTH, NaN off the terrain); NoData without them."""
    from vinecli.report.figure_base import NoData

    if run_dir is None or not (Path(run_dir) / DEPOSITION_JSON).is_file():
        raise NoData("no deposition in this run (no sprayer used)")
    doc = json.loads((Path(run_dir) / DEPOSITION_JSON).read_text(encoding="utf-8"))
    import rasterio

    with rasterio.open(Path(run_dir) / doc["geotiff"]["file"]) as ds:
        a = ds.read(1).astype(np.float64)
        nod = ds.nodata
    if nod is not None:
        a[a == nod] = np.nan
    return doc, np.flipud(a)


def _fmt_pct(v: Any) -> str:
    return f"{100 * v:.1f} %" if isinstance(v, (int, float)) and math.isfinite(v) else "n/a"


def _fmt(v: Any, unit: str, nd: int = 1) -> str:
    return f"{v:.{nd}f} {unit}" if isinstance(v, (int, float)) and math.isfinite(v) else "n/a"


def _fig23_key_figures(doc: dict[str, Any], nominal: Any, m: dict[str, Any], faults: list[Any]) -> list[str]:
    """The key figures printed beside fig. 23's map (deposition.json ``doc``, its metrics ``m``)."""
    tot = doc.get("totals") or {}
    sp = doc.get("spray_phase") or {}
    passes = sp.get("passes") or {}
    n_rows = len(doc.get("rows") or [])
    in_tol = sum(1 for r in doc.get("rows") or [] if isinstance(r.get("mean_rate_lpha"), (int, float))
                 and isinstance(nominal, (int, float)) and nominal > 0
                 and abs(r["mean_rate_lpha"] / nominal - 1.0) <= float((doc.get("dose_bands") or {}).get("rate_tolerance", 0.15)))
    lines = [
        "Where the liquid landed",
        f"emitted            {_fmt(tot.get('emitted_l'), 'L', 3)}",
        f"asked rate         {_fmt(nominal, 'L/ha')}",
        f"swath (geometric)  {_fmt(sp.get('swath_m'), 'm', 2)}",
        f"effective swath    {_fmt(sp.get('effective_swath_m'), 'm', 2)}",
        f"passes             {passes.get('count', 'n/a')} x {_fmt(sp.get('track_width_m'), 'm', 2)} ({passes.get('mode', '')})",
        f"rows within band   {in_tol} of {n_rows}",
        f"dose faults        {len(faults)}",
        f"mean on rows       {_fmt(m.get('mean_rate_lpha_on_rows'), 'L/ha')}",
        f"CV along rows      {_fmt_pct(m.get('deposit_cv_on_rows'))}",
        f"rows covered >=50% {_fmt_pct(m.get('row_coverage_fraction'))}",
        f"in the row bands   {_fmt_pct(m.get('deposit_on_rows_fraction'))}",
        f"outside the fence  {_fmt_pct(m.get('drift_outside_fence_fraction'))}",
        f"off the map        {_fmt(tot.get('off_grid_l'), 'L', 4)}",
        f"balance error      {tot.get('balance_error', float('nan')):.1e}",
    ]
    return lines


def fig23_deposition(data: Any) -> bytes:
    """Application rate map (L/ha) over the terrain with the rows, the flown path and the fence."""
    from matplotlib import colormaps
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import LightSource
    from matplotlib.figure import Figure

    from vinecli.report.figure_base import C_FAIL, DPI, SIZES, png_bytes, set_title

    doc, rate = load_deposition(getattr(data, "run_dir", None))
    g = doc["grid"]
    x0, y0, cell, nx, ny = g["x0_m"], g["y0_m"], g["cell_m"], g["nx"], g["ny"]
    ext = (x0, x0 + nx * cell, y0, y0 + ny * cell)
    m = doc.get("metrics") or {}
    nominal = m.get("nominal_rate_lpha")
    fig = Figure(figsize=SIZES["fig23"], dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.07, 0.07, 0.55, 0.85))
    cax = fig.add_axes((0.66, 0.40, 0.018, 0.50))  # moved next to the map once its aspect is applied
    pv = data.preview
    if pv is not None and pv["x"].size > 1 and pv["y"].size > 1:
        pext = (pv["x"][0], pv["x"][-1], pv["y"][0], pv["y"][-1])
        dx, dy = abs(pv["x"][1] - pv["x"][0]), abs(pv["y"][1] - pv["y"][0])
        shade = LightSource(azdeg=315, altdeg=45).hillshade(pv["z"], vert_exag=3.0, dx=dx, dy=dy)
        ax.imshow(shade, extent=pext, origin="lower", cmap="gray", alpha=0.5, aspect="equal", zorder=0)
    finite = rate[np.isfinite(rate)]
    vmax = float(np.max(finite)) if finite.size else 1.0
    if isinstance(nominal, (int, float)) and math.isfinite(nominal) and nominal > 0:
        # colour range: up to 3x the asked rate, or further when most of the wet area is above that (overdosed
        # field: keep its pattern visible); a few hot spots beyond are shown as the top colour
        wet = finite[finite > 0.02 * nominal]
        p98 = float(np.percentile(wet, 98)) if wet.size else 0.0
        vmax = min(vmax, max(3.0 * nominal, p98))
    vmax = max(vmax, 1e-9)
    shown = np.where(rate > 0.02 * vmax, rate, np.nan)  # dry cells stay transparent over the terrain
    cmap = colormaps["viridis_r"].copy()
    im = ax.imshow(shown, extent=ext, origin="lower", cmap=cmap, vmin=0.0, vmax=vmax, alpha=0.9, aspect="equal",
                   zorder=1, interpolation="nearest")
    cb = fig.colorbar(im, cax=cax, extend="max" if float(np.nanmax(rate, initial=0)) > vmax else "neither")
    cb.set_label("application rate, L/ha")
    if isinstance(nominal, (int, float)) and math.isfinite(nominal) and nominal <= vmax:
        cb.ax.axhline(nominal, color="k", lw=2.0)
        cb.ax.axhline(0.5 * nominal, color="k", lw=1.2, ls=":")
        cb.ax.text(-0.3, nominal, "asked ", fontsize=7, va="center", ha="right", transform=cb.ax.get_yaxis_transform())
        cb.ax.text(-0.3, 0.5 * nominal, "50 % ", fontsize=7, va="center", ha="right",
                   transform=cb.ax.get_yaxis_transform())
    summary_world = (data.summary or {}).get("world") or {}
    all_rows = summary_world.get("rows_enu") or []
    targets = [r["polyline_enu"] for r in doc.get("rows", [])]
    for i, r in enumerate(all_rows):
        r = np.asarray(r, float)
        if r.ndim == 2 and len(r) >= 2:
            ax.plot(r[:, 0], r[:, 1], color="#1b5e20", lw=0.6, alpha=0.6, zorder=2, label="vine rows" if i == 0 else None)
    for i, r in enumerate(targets):
        r = np.asarray(r, float)
        ax.plot(r[:, 0], r[:, 1], color="#e65100", lw=1.3, ls=(0, (3, 4)), zorder=6,
                label="targeted rows" if i == 0 else None)
    c = data.cols
    if data.has("pos_enu_x_m", "pos_enu_y_m"):
        x, y = c["pos_enu_x_m"], c["pos_enu_y_m"]
        ax.plot(x, y, color="#424242", lw=0.7, alpha=0.8, zorder=4, label="flown path")
        if data.has("tank_flow_lps"):
            on = c["tank_flow_lps"] > 0
            ax.plot(np.where(on, x, np.nan), np.where(on, y, np.nan), color="k", lw=1.4, zorder=5,
                    label="sprayer on")
    bps = [e["data"]["breakpoint_enu"] for e in data.events
           if e.get("kind") == "sortie" and (e.get("data") or {}).get("breakpoint_enu")]
    if bps:  # where a sortie stopped and the next one resumed
        b = np.asarray(bps, float)
        ax.plot(b[:, 0], b[:, 1], "o", ms=7, mfc="none", mec="#6a1b9a", mew=1.6, zorder=7,
                label=f"sortie breakpoints ({len(bps)})")
    faults = doc.get("dose_faults") or []
    for i, f in enumerate(faults):  # where the dose left its band
        p = f.get("position_enu")
        if p:
            ax.plot(p[0], p[1], "s" if f["kind"] == "hot" else "v", ms=8, mfc="none",
                    mec=C_FAIL if f["kind"] == "hot" else "#1565c0", mew=1.6, zorder=8,
                    label=("dose fault (hot / gap)" if i == 0 else None))
    fence = doc.get("geofence_polygon_enu") or (summary_world.get("geofence") or {}).get("polygon_enu") or []
    if len(fence) >= 3:
        f = np.asarray(list(fence) + [fence[0]], float)
        ax.plot(f[:, 0], f[:, 1], color=C_FAIL, ls="--", lw=1.2, zorder=5, label="geofence")
    # view: the wet area, the targeted rows and the path, with a margin
    wet = np.argwhere(np.nan_to_num(rate) > 0.02 * vmax)
    pts = []
    if wet.size:
        pts.append(np.column_stack([x0 + (wet[:, 1] + 0.5) * cell, y0 + (wet[:, 0] + 0.5) * cell]))
    pts += [np.asarray(r, float) for r in targets]
    if pts:
        allp = np.vstack(pts)
        lo, hi = allp.min(axis=0) - 2.0, allp.max(axis=0) + 2.0
        ax.set_xlim(max(lo[0], ext[0]), min(hi[0], ext[1]))
        ax.set_ylim(max(lo[1], ext[2]), min(hi[1], ext[3]))
    ax.set_xlabel("east x, m (ENU)")
    ax.set_ylabel("north y, m (ENU)")
    ax.apply_aspect()
    pos = ax.get_position()
    cax.set_position((pos.x1 + 0.07, pos.y0 + 0.35 * pos.height, 0.018, 0.6 * pos.height))
    xt = min(pos.x1 + 0.19, 0.745)
    fig.legend(*ax.get_legend_handles_labels(), fontsize=8, loc="lower left", bbox_to_anchor=(xt, pos.y0),
               frameon=False)
    lines = _fig23_key_figures(doc, nominal, m, faults)
    fig.text(xt, pos.y1, "\n".join(lines), fontsize=9, family="monospace", va="top")
    set_title(fig, data, "Fig. 23  Spray deposition, L/ha")
    return png_bytes(fig)


def fig24_row_coverage(data: Any) -> bytes:
    """Per targeted row: rate along its planned stretch against the asked rate and the dose bands, and its mean
    (with the lowest and highest dose window) against the rate tolerance."""
    from vinecli.report.figure_base import C_FAIL, C_OK, NoData, new_figure, png_bytes, set_title

    doc, _rate = load_deposition(getattr(data, "run_dir", None))
    rows = doc.get("rows") or []
    if not rows:
        raise NoData("no targeted rows to chart")
    nominal = (doc.get("metrics") or {}).get("nominal_rate_lpha")
    bands = doc.get("dose_bands") or {"rate_tolerance": 0.15, "hot_ratio": 1.3, "gap_ratio": 0.6}
    tol = float(bands["rate_tolerance"])
    fig, axes = new_figure("fig24", rows=2, cols=1, sharex=False)
    fig.subplots_adjust(hspace=0.35)
    ax, axb = axes[0, 0], axes[1, 0]
    cmap_n = max(len(rows), 1)
    from matplotlib import colormaps

    cm = colormaps["tab10" if cmap_n <= 10 else "viridis"]
    for i, r in enumerate(rows):
        rate = np.array([np.nan if v is None else v for v in r["rate_lpha"]], float)
        s = (np.arange(rate.size) + 0.5) * float(r.get("segment_m", 0.5))
        planned = r.get("planned_m") or [0.0, float(r.get("length_m", s[-1] if s.size else 0.0))]
        inside = (s >= planned[0]) & (s <= planned[1])
        ax.plot(np.where(inside, s, np.nan), rate, lw=1.0, color=cm(i % 10 if cmap_n <= 10 else i / cmap_n),
                label=f"row {r['row']}")
    ok_nominal = isinstance(nominal, (int, float)) and math.isfinite(nominal) and nominal > 0
    if ok_nominal:
        ax.axhspan((1 - tol) * nominal, (1 + tol) * nominal, color="k", alpha=0.07, label=f"asked ±{tol:.0%}")
        ax.axhline(nominal, color="k", lw=1.2, label=f"asked {nominal:.1f} L/ha")
        ax.axhline(float(bands["hot_ratio"]) * nominal, color=C_FAIL, lw=0.9, ls="--",
                   label=f"hot spot > {float(bands['hot_ratio']):g}x")
        ax.axhline(float(bands["gap_ratio"]) * nominal, color="#1565c0", lw=0.9, ls="--",
                   label=f"gap < {float(bands['gap_ratio']):g}x")
    ax.set_xlabel("distance along the row (its planned stretch), m")
    ax.set_ylabel("rate in the row band, L/ha")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=min(6, len(rows) + 4), loc="upper right")
    ax.set_ylim(bottom=0, top=max(ax.get_ylim()[1], 1.6 * nominal if ok_nominal else 0.0))
    names = [str(r["row"]) for r in rows]
    means = np.array([float(r["mean_rate_lpha"]) / nominal * 100 if ok_nominal and r.get("mean_rate_lpha") is not None
                      else np.nan for r in rows])
    lo = np.array([100 * r["window_ratio"][0] if r.get("window_ratio") else np.nan for r in rows])
    hi = np.array([100 * r["window_ratio"][1] if r.get("window_ratio") else np.nan for r in rows])
    good = [bool(abs(m / 100 - 1) <= tol and not r.get("faults")) for m, r in zip(means, rows, strict=True)]
    axb.bar(names, np.nan_to_num(means), color=[C_OK if g else C_FAIL for g in good])
    axb.errorbar(np.arange(len(rows)), np.nan_to_num(means), yerr=[np.nan_to_num(means - lo), np.nan_to_num(hi - means)],
                 fmt="none", ecolor="k", elinewidth=0.8, capsize=2, label=f"lowest / highest {bands.get('window_m', 1.0):g} m")
    axb.axhspan(100 * (1 - tol), 100 * (1 + tol), color="k", alpha=0.07)
    axb.axhline(100, color="k", lw=0.8)
    axb.set_ylim(0, max(140.0, float(np.nanmax(hi, initial=0.0)) * 1.05))
    axb.set_xlabel("targeted row (index in the mission's rows)")
    axb.set_ylabel("row mean / asked rate, %")
    axb.legend(fontsize=7, loc="lower right")
    axb.grid(alpha=0.3, axis="y")
    set_title(fig, data, "Fig. 24  Dose along the targeted rows")
    return png_bytes(fig)
