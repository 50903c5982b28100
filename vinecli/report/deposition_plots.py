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
    if not (isinstance(v, (int, float)) and math.isfinite(v)):
        return "n/a"
    return f"{(v if abs(v) >= 0.5 * 10.0 ** -nd else 0.0):.{nd}f} {unit}"  # rounding noise is no "-0.0000"


def _asked(nominal: Any) -> bool:
    return isinstance(nominal, (int, float)) and math.isfinite(nominal) and nominal > 0


def dose_scale(nominal: Any, rates: np.ndarray) -> tuple[Any, Any]:
    """(colour map, norm) of an application rate (L/ha) as a grower reads it: a diverging scale fixed on the asked
    rate, pale yellow there, blue below (0.6x: light blue), red above (1.3x: orange); 0 to twice the asked rate, or
    further when most of the wet area is above that (an overdosed field keeps its pattern). The same colour means the
    same share of the asked rate in every run. Without an asked rate: viridis from 0 to the highest rate."""
    from matplotlib import colormaps
    from matplotlib.colors import Normalize, TwoSlopeNorm

    finite = rates[np.isfinite(rates)]
    top = float(np.max(finite)) if finite.size else 1.0
    if not _asked(nominal):
        return colormaps["viridis_r"], Normalize(0.0, max(top, 1e-9))
    wet = finite[finite > 0.02 * nominal]
    p98 = float(np.percentile(wet, 98)) if wet.size else 0.0
    return colormaps["RdYlBu_r"], TwoSlopeNorm(vmin=0.0, vcenter=float(nominal), vmax=max(2.0 * nominal, p98))


def _mark_bands(cb: Any, nominal: Any, bands: dict[str, Any]) -> None:
    """The asked rate and the hot / gap bands as the ticks of a colour bar of :func:`dose_scale` (L/ha and what
    they are), with lines across it."""
    if not _asked(nominal):
        return
    hot, gap = float(bands.get("hot_ratio", 1.3)), float(bands.get("gap_ratio", 0.6))
    top = float(cb.norm.vmax)
    marks = {0.0: ("0", 0.0, "-"), gap * nominal: (f"{gap * nominal:.3g} gap {gap:g}x", 1.2, "--"),
             nominal: (f"{nominal:.3g} asked", 2.0, "-"), hot * nominal: (f"{hot * nominal:.3g} hot {hot:g}x", 1.2, "--"),
             top: (f"{top:.3g}", 0.0, "-")}
    marks = {v: m for v, m in marks.items() if v <= top}
    cb.set_ticks(list(marks), labels=[m[0] for m in marks.values()], fontsize=7)
    line = cb.ax.axvline if cb.orientation == "horizontal" else cb.ax.axhline
    for v, (_lab, lw, ls) in marks.items():
        if lw > 0:
            line(v, color="k", lw=lw, ls=ls)


def _fig23_key_figures(doc: dict[str, Any], nominal: Any, m: dict[str, Any], faults: list[Any]) -> list[str]:
    """The key figures printed beside fig. 23's map (deposition.json ``doc``, its metrics ``m``)."""
    tot = doc.get("totals") or {}
    sp = doc.get("spray_phase") or {}
    passes = sp.get("passes") or {}
    n_rows = len(doc.get("rows") or [])
    in_tol = sum(1 for r in doc.get("rows") or [] if isinstance(r.get("mean_rate_lpha"), (int, float))
                 and isinstance(nominal, (int, float)) and nominal > 0
                 and abs((r.get("mean_rate_per_pass_lpha") or r["mean_rate_lpha"]) / nominal - 1.0)
                 <= float((doc.get("dose_bands") or {}).get("rate_tolerance", 0.15)))
    lines = [
        "Where the liquid landed",
        f"emitted            {_fmt(tot.get('emitted_l'), 'L', 3)}",
        f"asked rate         {_fmt(nominal, 'L/ha')}",
        f"swath (geometric)  {_fmt(sp.get('swath_m'), 'm', 2)}",
        f"effective swath    {_fmt(sp.get('effective_swath_m'), 'm', 2)}",
        f"passes             {passes.get('count', 'n/a')} x {_fmt(sp.get('track_width_m'), 'm', 2)}",
        f"  laid out         {passes.get('mode', 'n/a')}",
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


#: fig. 23's map: the height of a tall field's map, the width of a wide one (inches); the side panel's width
MAP_TALL_IN, MAP_WIDE_IN, SIDE_IN = 6.8, 10.0, 4.6


def _fig23_view(rate: np.ndarray, ext: tuple[float, float, float, float], cell: float, vmax: float,
                targets: list[Any]) -> tuple[float, float, float, float]:
    """The box fig. 23 shows: the wet area and the targeted rows with 2 m around, inside the grid."""
    wet = np.argwhere(np.nan_to_num(rate) > 0.02 * vmax)
    pts = [np.column_stack([ext[0] + (wet[:, 1] + 0.5) * cell, ext[2] + (wet[:, 0] + 0.5) * cell])] if wet.size else []
    pts += [np.asarray(r, float) for r in targets]
    if not pts:
        return ext
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0) - 2.0, allp.max(axis=0) + 2.0
    return max(lo[0], ext[0]), min(hi[0], ext[1]), max(lo[1], ext[2]), min(hi[1], ext[3])


def _fig23_layout(aspect: float) -> tuple[Any, Any, Any, tuple[float, float], bool]:
    """(figure, map axes, colour-bar axes, where the key figures go (figure fraction), side layout) for a field of
    ``aspect`` = height / width: a tall or square field gets its map at full height with the colour bar, the key
    figures and the legend beside it; a wide one its map at full width with them below."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from vinecli.report.figure_base import DPI

    side = aspect >= 0.8
    if side:
        hm = MAP_TALL_IN if aspect >= MAP_TALL_IN / 7.5 else 7.5 * aspect
        wm = hm / aspect
        w, h = 0.9 + wm + 0.4 + SIDE_IN, hm + 1.2
        fig = Figure(figsize=(max(w, 8.0), h), dpi=DPI)
        w = max(w, 8.0)
        ax = fig.add_axes((0.9 / w, 0.7 / h, wm / w, hm / h))
        cax = fig.add_axes(((0.9 + wm + 0.45) / w, 0.7 / h + 0.42 * hm / h, 0.18 / w, 0.55 * hm / h))
        text = ((0.9 + wm + 1.75) / w, (0.7 + hm) / h)
    else:
        wm = MAP_WIDE_IN
        hm = max(wm * aspect, 2.0)
        w, h = wm + 1.4, hm + 1.1 + 2.9
        fig = Figure(figsize=(w, h), dpi=DPI)
        ax = fig.add_axes((0.9 / w, 3.5 / h, wm / w, hm / h))
        cax = fig.add_axes((0.9 / w, 2.55 / h, 0.45 * wm / w, 0.16 / h))
        text = ((0.9 + 0.55 * wm) / w, 2.95 / h)
    FigureCanvasAgg(fig)
    return fig, ax, cax, text, side


def fig23_deposition(data: Any) -> bytes:
    """Application rate map (L/ha) over the terrain with the rows, the flown path and the fence; the figure takes
    the field's shape (:func:`_fig23_layout`)."""
    from matplotlib.colors import LightSource

    from vinecli.report.figure_base import C_FAIL, png_bytes, set_title

    doc, rate = load_deposition(getattr(data, "run_dir", None))
    g = doc["grid"]
    x0, y0, cell, nx, ny = g["x0_m"], g["y0_m"], g["cell_m"], g["nx"], g["ny"]
    ext = (x0, x0 + nx * cell, y0, y0 + ny * cell)
    m = doc.get("metrics") or {}
    nominal = m.get("nominal_rate_lpha")
    cmap, norm = dose_scale(nominal, rate)
    vmax = float(norm.vmax)
    targets = [r["polyline_enu"] for r in doc.get("rows", [])]
    view = _fig23_view(rate, ext, cell, vmax, targets)
    fig, ax, cax, (xt, yt), side = _fig23_layout((view[3] - view[2]) / max(view[1] - view[0], 1e-9))
    pv = data.preview
    if pv is not None and pv["x"].size > 1 and pv["y"].size > 1:
        pext = (pv["x"][0], pv["x"][-1], pv["y"][0], pv["y"][-1])
        dx, dy = abs(pv["x"][1] - pv["x"][0]), abs(pv["y"][1] - pv["y"][0])
        shade = LightSource(azdeg=315, altdeg=45).hillshade(pv["z"], vert_exag=3.0, dx=dx, dy=dy)
        ax.imshow(shade, extent=pext, origin="lower", cmap="gray", alpha=0.5, aspect="equal", zorder=0)
    shown = np.where(rate > 0.02 * vmax, rate, np.nan)  # dry cells stay transparent over the terrain
    im = ax.imshow(shown, extent=ext, origin="lower", cmap=cmap, norm=norm, alpha=0.9, aspect="equal",
                   zorder=1, interpolation="nearest")
    cb = fig.colorbar(im, cax=cax, orientation="vertical" if side else "horizontal",
                      extend="max" if float(np.nanmax(rate, initial=0)) > vmax else "neither")
    cb.set_label("application rate, L/ha")
    _mark_bands(cb, nominal, doc.get("dose_bands") or {})
    summary_world = (data.summary or {}).get("world") or {}
    for i, r in enumerate(summary_world.get("rows_enu") or []):
        r = np.asarray(r, float)
        if r.ndim == 2 and len(r) >= 2:
            ax.plot(r[:, 0], r[:, 1], color="#66bb6a", lw=0.6, alpha=0.8, zorder=2, label="vine rows" if i == 0 else None)
    for i, r in enumerate(targets):
        r = np.asarray(r, float)
        ax.plot(r[:, 0], r[:, 1], color="#1b5e20", lw=1.1, ls=(0, (3, 4)), zorder=6,
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
    ax.set_xlim(view[0], view[1])
    ax.set_ylim(view[2], view[3])
    ax.set_xlabel("east x, m (ENU)")
    ax.set_ylabel("north y, m (ENU)")
    fig.text(xt, yt, "\n".join(_fig23_key_figures(doc, nominal, m, faults)), fontsize=8.5, family="monospace",
             va="top")
    pos = ax.get_position()
    h_in = fig.get_size_inches()[1]
    anchor = (xt, yt - 2.55 / h_in) if side else (pos.x0, 2.4 / h_in)  # under the key figures / under the map
    fig.legend(*ax.get_legend_handles_labels(), fontsize=8, loc="upper left", bbox_to_anchor=anchor, frameon=False,
               ncol=1 if side else 2)
    set_title(fig, data, "Fig. 23  Spray deposition, L/ha")
    return png_bytes(fig, colour_scale=True)


def _row_rates(r: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """(segment centres along the row m, rate L/ha with NaN outside the planned stretch) of a deposition.json row; per
    pass for a phase that repeats its passes (its ``passes``: judged per pass, missions/repeat_passes.py)."""
    rate = np.array([np.nan if v is None else v for v in r["rate_lpha"]], float)
    if r.get("passes") is not None and len(r["passes"]) == rate.size:
        rate = rate / np.maximum(np.asarray(r["passes"], float), 1.0)
    s = (np.arange(rate.size) + 0.5) * float(r.get("segment_m", 0.5))
    planned = r.get("planned_m") or [0.0, float(r.get("length_m", s[-1] if s.size else 0.0))]
    return s, np.where((s >= planned[0]) & (s <= planned[1]), rate, np.nan)


def _row_name(r: dict[str, Any]) -> str:
    """The row's number in the world (the mission's own index for rows it gives as polylines)."""
    w = r.get("world_row")
    return str(w if w is not None else r["row"])


#: above this many targeted rows fig. 24 draws the rates as a map (a row per line) instead of one curve per row
_CURVES_MAX = 6


def _rate_curves(ax: Any, rows: list[dict[str, Any]], nominal: Any, bands: dict[str, Any]) -> None:
    """Fig. 24 top, few rows: the rate along each row against the asked band and the hot / gap lines (legend beside)."""
    from matplotlib import colormaps

    from vinecli.report.figure_base import C_FAIL

    cm = colormaps["tab10"]
    for i, r in enumerate(rows):
        s, rate = _row_rates(r)
        ax.plot(s, rate, lw=1.0, color=cm(i % 10), label=f"row {_row_name(r)}")
    tol = float(bands["rate_tolerance"])
    if _asked(nominal):
        ax.axhspan((1 - tol) * nominal, (1 + tol) * nominal, color="k", alpha=0.07, label=f"asked ±{tol:.0%}")
        ax.axhline(nominal, color="k", lw=1.2, label=f"asked {nominal:.1f} L/ha")
        ax.axhline(float(bands["hot_ratio"]) * nominal, color=C_FAIL, lw=0.9, ls="--",
                   label=f"hot spot > {float(bands['hot_ratio']):g}x")
        ax.axhline(float(bands["gap_ratio"]) * nominal, color="#1565c0", lw=0.9, ls="--",
                   label=f"gap < {float(bands['gap_ratio']):g}x")
    ax.set_ylabel("rate in the row band" + (" per pass" if any(r.get("passes") for r in rows) else "") + ", L/ha")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax.set_ylim(bottom=0, top=max(ax.get_ylim()[1], 1.6 * nominal if _asked(nominal) else 0.0))


def _rate_map(fig: Any, ax: Any, rows: list[dict[str, Any]], nominal: Any, bands: dict[str, Any]) -> None:
    """Fig. 24 top, many rows: the rate along every row as a map (a row per line, the colours of fig. 23), the dose
    faults framed."""
    from matplotlib.patches import Rectangle

    from vinecli.report.figure_base import C_FAIL

    profiles = [_row_rates(r) for r in rows]
    seg = float(rows[0].get("segment_m", 0.5))
    n = max(p[1].size for p in profiles)
    grid = np.full((len(rows), n), np.nan)
    for k, (_s, rate) in enumerate(profiles):
        grid[k, :rate.size] = rate
    cmap, norm = dose_scale(nominal, grid)
    im = ax.imshow(grid, aspect="auto", origin="lower", cmap=cmap, norm=norm, interpolation="nearest",
                   extent=(0.0, n * seg, -0.5, len(rows) - 0.5))
    cb = fig.colorbar(im, ax=ax, pad=0.01, fraction=0.04)
    cb.set_label("L/ha", fontsize=8)
    _mark_bands(cb, nominal, bands)
    for k, r in enumerate(rows):
        for f in r.get("faults") or []:
            ax.add_patch(Rectangle((f["from_m"], k - 0.5), f["to_m"] - f["from_m"], 1.0, fill=False, lw=1.5,
                                   ec=C_FAIL if f["kind"] == "hot" else "#0d47a1"))
    step = max(1, int(math.ceil(len(rows) / 20)))
    ax.set_yticks(range(0, len(rows), step), [_row_name(r) for r in rows][::step], fontsize=7)
    ax.set_ylabel("row")


def fig24_row_coverage(data: Any) -> bytes:
    """Per targeted row: rate along its planned stretch against the asked rate and the dose bands (curves for a few
    rows, a map for many), and its mean (with the lowest and highest dose window) against the rate tolerance."""
    from vinecli.report.figure_base import C_FAIL, C_OK, NoData, new_figure, png_bytes, set_title

    doc, _rate = load_deposition(getattr(data, "run_dir", None))
    rows = doc.get("rows") or []
    if not rows:
        raise NoData("no targeted rows to chart")
    nominal = (doc.get("metrics") or {}).get("nominal_rate_lpha")
    bands = {"rate_tolerance": 0.15, "hot_ratio": 1.3, "gap_ratio": 0.6, **(doc.get("dose_bands") or {})}
    tol = float(bands["rate_tolerance"])
    fig, axes = new_figure("fig24", rows=2, cols=1, sharex=False)
    fig.subplots_adjust(hspace=0.35, right=0.84)
    ax, axb = axes[0, 0], axes[1, 0]
    if len(rows) <= _CURVES_MAX:
        _rate_curves(ax, rows, nominal, bands)
    else:
        _rate_map(fig, ax, rows, nominal, bands)
    ax.set_xlabel("distance along the row (its planned stretch), m")
    names = [_row_name(r) for r in rows]
    # a phase that repeats its passes is judged per pass (missions/repeat_passes.py): its windows are per pass too
    means = np.array([float(r.get("mean_rate_per_pass_lpha") or r["mean_rate_lpha"]) / nominal * 100
                      if _asked(nominal) and r.get("mean_rate_lpha") is not None else np.nan for r in rows])
    lo = np.array([100 * r["window_ratio"][0] if r.get("window_ratio") else np.nan for r in rows])
    hi = np.array([100 * r["window_ratio"][1] if r.get("window_ratio") else np.nan for r in rows])
    good = [bool(abs(m / 100 - 1) <= tol and not r.get("faults")) for m, r in zip(means, rows, strict=True)]
    axb.bar(names, np.nan_to_num(means), color=[C_OK if g else C_FAIL for g in good])
    axb.errorbar(np.arange(len(rows)), np.nan_to_num(means), yerr=[np.nan_to_num(means - lo), np.nan_to_num(hi - means)],
                 fmt="none", ecolor="k", elinewidth=0.8, capsize=2, label=f"lowest / highest {bands.get('window_m', 1.0):g} m")
    axb.axhspan(100 * (1 - tol), 100 * (1 + tol), color="k", alpha=0.07, label=f"asked ±{tol:.0%}")
    axb.axhline(100, color="k", lw=0.8)
    axb.set_ylim(0, max(140.0, float(np.nanmax(hi, initial=0.0)) * 1.05))
    axb.set_xlabel("targeted row (the world's number when the mission names world rows, else its index)")
    axb.set_ylabel("row mean / asked rate, %")
    axb.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    axb.grid(alpha=0.3, axis="y")
    set_title(fig, data, "Fig. 24  Dose along the targeted rows")
    return png_bytes(fig, colour_scale=len(rows) > _CURVES_MAX)
