"""The spray budget figure of a run (docs/budget.md): where the spray went, per row, and the drift curve.

Left: one stacked bar for the whole run, then one per sprayed row (the spray released over that row):
canopy, ground in the field, ground off the field, airborne out of the drift domain, evaporated, in %
of the volume. Right: sedimenting drift downwind of the last row, % of the applied rate, against the
distance on log-log axes (the far-field model's curve reaches 50 m), with the German basic drift values
(Rautmann et al. 2001, 90th percentile, one application: vineyard air-blast late and early, arable boom)
for scale and the default drift ceiling at 5 m. :func:`trial_comparison` draws the model against a field
trial's numbers (Biglia et al. 2022's band and broadcast deposits, benchmarks/published_trials.py). Read from ``budget.json``; runs without one raise :class:`~vinecli.report.figure_base.NoData`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["BASIC_DRIFT", "BUDGET_COLOURS", "RAUTMANN_VINES_LATE", "draw_hedges", "fig25_budget", "load_budget",
           "trial_comparison"]

#: destination -> (label, colour)
BUDGET_COLOURS = {
    "canopy": ("on the canopy", "#2e7d32"),
    "ground_in_field": ("ground, in the field", "#a1887f"),
    "ground_off_field": ("ground, off the field", "#ef6c00"),
    "airborne_out": ("airborne, out", "#c62828"),
    "evaporated": ("evaporated", "#90caf9"),
}
DRIFT_FLOOR_PCT = 1e-3  # the drift axis' floor, % of applied: below it the run put nothing on the ground there
#: distance m -> drift % of applied, late vines, 90th percentile of one application (Rautmann et al. 2001)
RAUTMANN_VINES_LATE = {3.0: 8.02, 5.0: 3.62, 10.0: 1.23, 15.0: 0.65, 20.0: 0.42, 30.0: 0.22, 50.0: 0.10}


def load_budget(run_dir: Path | None) -> dict[str, Any]:
    """budget.json of a run directory; NoData when the run has none."""
    from vinecli.report.figure_base import NoData
    from vinecli.runs.budget_out import BUDGET_JSON

    if run_dir is None or not (Path(run_dir) / BUDGET_JSON).is_file():
        raise NoData("no deposition in this run (no sprayer used)")
    return json.loads((Path(run_dir) / BUDGET_JSON).read_text(encoding="utf-8"))


def draw_hedges(ax: Any, data: Any, rows: list[Any]) -> None:
    """Each row's hedge (its width, from the run's budget.json) as a green band on a top view (world ENU, m)."""
    from matplotlib.patches import Polygon

    try:
        doc = load_budget(getattr(data, "run_dir", None))
    except Exception:  # noqa: BLE001 - NoData or an unreadable budget: the view simply has no hedges
        return
    canopy = (doc.get("conditions") or {}).get("canopy") or {}
    label = "hedges (canopy)"
    for h in canopy.get("hedges") or []:
        if h.get("width_m", 0) <= 0 or h["row"] >= len(rows) or len(rows[h["row"]]) < 2:
            continue
        pts = np.asarray(rows[h["row"]], float)
        for a, b in zip(pts[:-1], pts[1:], strict=False):
            d = b - a
            n = np.array([-d[1], d[0]]) / (np.hypot(*d) or 1.0) * 0.5 * h["width_m"]
            ax.add_patch(Polygon([a + n, b + n, b - n, a - n], closed=True, facecolor="#66bb6a", alpha=0.45,
                                 edgecolor="none", zorder=1.5, label=label))
            label = None


#: a row gets its own bar when at least this share of the largest row's volume was released over it: in
#: broadcast mode the passes fly over every third row or so, and the rows between see only the trickle of
#: the turns and run-ins, whose shares (mostly off the field) say nothing about the row
MIN_ROW_RELEASE = 0.05


def _bars(ax: Any, doc: dict[str, Any]) -> None:
    labels = ["whole run"]
    shares = [doc["fractions"]]
    rows = [r for r in doc.get("rows") or [] if r.get("released_l", 0) > 0]
    top = max((r["released_l"] for r in rows), default=0.0)
    shown = [r for r in rows if r["released_l"] >= MIN_ROW_RELEASE * top]
    for r in shown:
        labels.append(f"row {r['row']}")
        shares.append(r["released"])
    if len(shown) < len(rows):
        ax.text(0.0, -0.16, f"{len(rows) - len(shown)} rows with < {MIN_ROW_RELEASE:.0%} of the largest row's "
                "release (no pass over them: turns, run-ins) not shown", transform=ax.transAxes, fontsize=7,
                va="top")
    y = np.arange(len(labels))[::-1].astype(float)
    y[0] += 0.8  # the whole run apart from the rows
    left = np.zeros(len(labels))
    for key, (lab, col) in BUDGET_COLOURS.items():
        v = np.array([100.0 * (s.get(key) or 0.0) for s in shares])
        ax.barh(y, v, left=left, color=col, height=0.7, label=lab, edgecolor="white", linewidth=0.5)
        for yi, li, vi in zip(y, left, v, strict=True):
            if vi >= 6.0:
                ax.text(li + vi / 2, yi, f"{vi:.0f}", ha="center", va="center", fontsize=8,
                        color="white" if key in ("canopy", "airborne_out") else "black")
        left += v
    ax.set_yticks(y, labels)
    ax.set_xlim(0, 100)
    ax.set_xlabel("share of the sprayed volume, %")
    ax.legend(fontsize=8, ncol=3, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
    ax.grid(alpha=0.3, axis="x")


#: German basic drift values (Rautmann et al. 2001; 90th percentiles, one application), % of applied, for scale
BASIC_DRIFT = {
    "vines, late (air-blast)": (RAUTMANN_VINES_LATE, "#616161", "s"),
    "vines, early (air-blast)": ({3.0: 2.70, 5.0: 1.18, 10.0: 0.39, 15.0: 0.20, 20.0: 0.13}, "#9e9e9e", "D"),
    "arable (boom)": ({3.0: 0.95, 5.0: 0.57, 10.0: 0.29, 15.0: 0.20, 20.0: 0.15}, "#8d6e63", "^"),
}


def _drift(ax: Any, doc: dict[str, Any]) -> None:
    """The run's drift curve against the reference values, both axes logarithmic (a regulator reads 3-50 m where
    the values are hundredths of the 1 m one); points with no drift sit on the axis' floor, marked "0"."""
    from matplotlib.ticker import FuncFormatter, NullLocator

    from vinecli.missions.budget_metrics import DEFAULT_DRIFT_5M_MAX_PCT

    pts = [(p["distance_m"], p["percent_of_applied"]) for p in doc.get("drift_curve") or []
           if p.get("percent_of_applied") is not None and math.isfinite(p["percent_of_applied"])]
    # % of applied: the log axis' bottom (a zero reading is drawn on it, open); lower when the far field is fainter
    positive = [v for _d, v in pts if v > 0]
    floor = min(DRIFT_FLOOR_PCT, 0.3 * min(positive)) if positive else DRIFT_FLOOR_PCT
    if pts:
        d, v = np.array(pts).T
        wet = v > 0
        ax.plot(d[wet], v[wet], marker="o", color="#c62828", lw=2, label="this run", zorder=3)
        if (~wet).any():  # none on the ground there: on the axis' floor, not lost below a log axis
            ax.plot(d[~wet], np.full(int((~wet).sum()), floor), marker="o", mfc="white", color="#c62828", ls="", ms=6,
                    clip_on=False, zorder=4, label="this run: nothing on the ground (drawn at the axis)")
        for di, vi in zip(d, v, strict=True):
            ax.annotate(f"{vi:.2g}" if vi > 0 else "0", (di, max(vi, floor)), xytext=(0, 6), textcoords="offset points",
                        ha="center", fontsize=7)
    for label, (vals, col, mk) in BASIC_DRIFT.items():
        rd, rv = np.array(list(vals.items())).T
        ax.plot(rd, rv, ls="--", marker=mk, ms=4, color=col, lw=1.0, label=f"basic drift, {label}")
    ax.plot([5.0], [DEFAULT_DRIFT_5M_MAX_PCT], marker="v", color="k", ls="", ms=8, label="ceiling at 5 m (check)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ticks = [1, 3, 5, 10, 15, 20, 30, 50]
    ax.set_xticks(ticks, [str(t) for t in ticks])
    ax.set_xlim(0.8, 60)
    top = max([100.0, *(p[1] for p in pts)])
    ax.set_ylim(floor, 1.5 * top)
    ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _pos: f"{y:g}"))
    ax.set_xlabel("distance downwind of the last row, m (log)")
    ax.set_ylabel("drift on the ground, % of applied (log)")
    dr = doc.get("drift") or {}
    # at a fixed height: matplotlib otherwise lays out the axes to place it (a quarter of the figure's time)
    ax.set_title("calm: both sides averaged" if dr.get("calm") else "downwind side", fontsize=9, loc="left", y=1.0,
                 pad=4)
    ax.xaxis.set_minor_locator(NullLocator())  # labelled majors only: log axes' minor ticks cost as much again
    ax.yaxis.set_minor_locator(NullLocator())
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")


def trial_comparison(ax: Any, rows: list[tuple[str, float, float]]) -> None:
    """Model against a field trial, side by side: ``rows`` of (label, paper, model), e.g. Biglia et al. 2022's
    band and broadcast canopy deposits and ground losses (benchmarks/published_trials.py)."""
    y = np.arange(len(rows))[::-1].astype(float)
    paper = np.array([r[1] for r in rows])
    model = np.array([r[2] for r in rows])
    ax.barh(y + 0.18, paper, height=0.35, color="#616161", label="field trial")
    ax.barh(y - 0.18, model, height=0.35, color="#2e7d32", label="vinecli")
    for yi, p, m in zip(y, paper, model, strict=True):
        ax.text(max(p, m) * 1.02, yi, f"{m / p:.2f}x" if p > 0 else "", va="center", fontsize=8)
    ax.set_yticks(y, [r[0] for r in rows])
    ax.set_xlim(0, 1.2 * float(max(paper.max(), model.max())))
    ax.set_xlabel("deposit, µL/cm² (standardised)")
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(alpha=0.3, axis="x")


def fig25_budget(data: Any) -> bytes:
    """Spray budget: stacked bars (whole run, each sprayed row) and the drift curve on a log distance axis."""
    from vinecli.report.figure_base import new_figure, png_bytes, set_title

    doc = load_budget(getattr(data, "run_dir", None))
    fig, axes = new_figure("fig25", rows=1, cols=2, sharex=False)
    fig.subplots_adjust(left=0.09, right=0.98, bottom=0.2, top=0.8, wspace=0.3)
    _bars(axes[0, 0], doc)
    _drift(axes[0, 1], doc)
    m = doc.get("metrics") or {}
    fr = doc.get("fractions") or {}
    cond = doc.get("conditions") or {}
    wind = cond.get("wind_mean_enu_mps") or [0.0, 0.0]
    spec = cond.get("drop_spectrum") or {}
    dep = m.get("budget_canopy_deposit_ulpcm2")
    note = (f"canopy {100 * fr.get('canopy', 0):.0f} %  ·  canopy deposit "
            f"{dep:.3g} µL/cm² of leaf" if isinstance(dep, (int, float)) and math.isfinite(dep) else
            f"canopy {100 * fr.get('canopy', 0):.0f} % (no canopy in this world)")
    note += (f"  ·  applied {cond.get('applied_lpha', float('nan')):.0f} L/ha  ·  wind {math.hypot(*wind):.1f} m/s"
             f"  ·  drops VMD {spec.get('vmd_um', float('nan')):.0f} µm  ·  balance error {doc.get('balance_error', 0):.1e}")
    fig.text(0.5, 0.03, note, ha="center", fontsize=9)
    set_title(fig, data, "Fig. 25  Where the spray went")
    return png_bytes(fig)
