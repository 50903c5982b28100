"""The dose figures of a run that flew segment rates (docs/dose.md §6), read from its ``as_applied.json``:

* fig26, the maps side by side (top view, world ENU m): the canopy segments' leaf-wall height (measured on the
  DSM, or given), the prescription, the rate the pump applied and the error, each segment painted on its strip of
  ground (± half the row spacing); rates on one scale, the error on a diverging one (±30 %);
* fig27: the error histogram (every 0.1 m of sprayed row: the pump's rate, and the deposit on the canopy band in
  outline, against the ±10 % band), the transition distance of every rate step against its bound (pump lag x
  speed), and the product: litres the uniform rate, the prescription and the pump used over the rows, with the
  saving.

Runs without segment rates raise :class:`~vinecli.report.figure_base.NoData`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["fig26_dose_maps", "fig27_dose_quality", "load_as_applied"]

ERROR_RANGE_PCT = 30.0


def load_as_applied(run_dir: Path | None) -> dict[str, Any]:
    """as_applied.json of a run directory; NoData when the run flew no segment rates."""
    from vinecli.report.figure_base import NoData
    from vinecli.runs.as_applied_out import AS_APPLIED_JSON

    if run_dir is None or not (Path(run_dir) / AS_APPLIED_JSON).is_file():
        raise NoData("no segment rates in this run (no canopy dose or prescription map)")
    return json.loads((Path(run_dir) / AS_APPLIED_JSON).read_text(encoding="utf-8"))


def _num(v: Any) -> float:
    return float(v) if isinstance(v, (int, float)) and math.isfinite(v) else math.nan


def _strips(doc: dict[str, Any]) -> list[np.ndarray]:
    from vinecli.gis.canopy_out import segment_strip

    half = 0.5 * float((doc.get("summary") or {}).get("spacing_m") or _spacing(doc))
    return [np.asarray(segment_strip(tuple(g["start_enu"]), tuple(g["end_enu"]), half)) for g in doc["segments"]]


def _spacing(doc: dict[str, Any]) -> float:
    """The row spacing the product was computed with (litres = rate x length x spacing / 10 000)."""
    segs = doc.get("segments") or []
    p = doc.get("product") or {}
    length = sum(g["s1_m"] - g["s0_m"] for g in segs if g["prescribed_lpha"] > 0)
    presc = sum(g["prescribed_lpha"] * (g["s1_m"] - g["s0_m"]) for g in segs)
    return 1e4 * _num(p.get("prescribed_l")) / presc if presc > 0 and length > 0 else 1.0


def fig26_dose_maps(data: Any) -> bytes:
    """Prescription, as-applied (pump) and error maps side by side."""
    import matplotlib
    from matplotlib.collections import PolyCollection

    from vinecli.report.figure_base import new_figure, png_bytes, set_title

    doc = load_as_applied(getattr(data, "run_dir", None))
    segs = doc["segments"]
    if not segs:
        from vinecli.report.figure_base import NoData

        raise NoData("no segments within the planned stretches")
    strips = _strips(doc)
    presc = np.array([_num(g["prescribed_lpha"]) for g in segs])
    pump = np.array([_num(g["pump_lpha"]) for g in segs])
    err = np.array([100.0 * _num(g["pump_error"]) for g in segs])
    top = float(np.nanmax(np.concatenate([presc, pump]))) or 1.0
    wall = np.array([_num(g.get("wall_height_m")) for g in segs])
    fig, axes = new_figure("fig26", rows=1, cols=4, sharex=True)
    fig.subplots_adjust(left=0.05, right=0.95, top=0.88, bottom=0.08, wspace=0.5)
    pts = np.concatenate(strips)
    panels = [("canopy: leaf-wall height, m", wall, "Greens", 0.0, float(np.nanmax(wall)) if np.isfinite(wall).any()
               and np.nanmax(wall) > 0 else 1.0),
              ("prescribed, L/ha", presc, "viridis", 0.0, top), ("applied by the pump, L/ha", pump, "viridis", 0.0, top),
              ("error, % (applied / prescribed - 1)", err, "RdBu_r", -ERROR_RANGE_PCT, ERROR_RANGE_PCT)]
    for ax, (title, vals, cmap, lo, hi) in zip(axes[0], panels, strict=True):
        pc = PolyCollection(strips, array=np.ma.masked_invalid(vals), cmap=matplotlib.colormaps[cmap],
                            edgecolors="none")
        pc.set_clim(lo, hi)
        ax.add_collection(pc)
        ax.set_xlim(pts[:, 0].min() - 1.0, pts[:, 0].max() + 1.0)
        ax.set_ylim(pts[:, 1].min() - 1.0, pts[:, 1].max() + 1.0)
        ax.set_aspect("equal", adjustable="box")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("east, m")
        fig.colorbar(pc, ax=ax, shrink=0.8)
    axes[0, 0].set_ylabel("north, m")
    s = doc.get("summary") or {}
    set_title(fig, data, f"dose maps: {s.get('dose') or (s.get('prescription') or {}).get('kind', 'prescription')}")
    return png_bytes(fig)


def _errors(doc: dict[str, Any], key: str) -> np.ndarray:
    out = []
    for b in doc.get("bins") or []:
        p = np.array([_num(v) for v in b["prescribed_lpha"]])
        a = np.array([_num(v) for v in b[key]])
        ok = p > 0
        out.append(100.0 * (a[ok] / p[ok] - 1.0))
    return np.concatenate(out) if out else np.zeros(0)


def fig27_dose_quality(data: Any) -> bytes:
    """Error histogram, transition distances against their bounds, product against a uniform rate."""
    from vinecli.report.figure_base import C_FAIL, C_OK, new_figure, png_bytes, set_title

    doc = load_as_applied(getattr(data, "run_dir", None))
    tol = 100.0 * float(doc.get("tolerance", 0.1))
    fig, axes = new_figure("fig27", rows=1, cols=3, sharex=False)
    fig.subplots_adjust(left=0.06, right=0.98, top=0.84, bottom=0.14, wspace=0.3)
    ax = axes[0, 0]
    edges = np.linspace(-60, 60, 49)
    pump, dep = _errors(doc, "pump_lpha"), _errors(doc, "deposit_lpha")
    if pump.size:
        ax.hist(np.clip(pump, -60, 60), bins=edges, weights=np.full(pump.size, 100.0 / pump.size), color="#1f77b4",
                label="pump")
    if np.isfinite(dep).any():
        d = dep[np.isfinite(dep)]
        ax.hist(np.clip(d, -60, 60), bins=edges, weights=np.full(d.size, 100.0 / d.size), histtype="step",
                color="k", label="deposit (canopy band)")
    ax.axvspan(-tol, tol, color=C_OK, alpha=0.12, label=f"±{tol:.0f} %")
    s = doc.get("summary") or {}
    ax.set_title(f"within ±{tol:.0f} %: pump {100 * _num(s.get('in_band_fraction')):.1f} %, deposit "
                 f"{100 * _num(s.get('in_band_fraction_deposit')):.1f} % of the row length", fontsize=8)
    ax.set_xlabel("error, % (clipped at ±60)")
    ax.set_ylabel("share of the sprayed row length, %")
    ax.legend(fontsize=7)
    ax = axes[0, 1]
    steps = [t for t in doc.get("transitions") or [] if t.get("judged")]
    if steps:
        b = np.array([t["bound_m"] for t in steps])
        d = np.array([t["distance_m"] for t in steps])
        ok = np.array([t["within_bound"] for t in steps])
        ax.scatter(b[ok], d[ok], s=14, color=C_OK, label="within its bound")
        ax.scatter(b[~ok], d[~ok], s=18, color=C_FAIL, marker="x", label="over its bound")
        top = float(max(b.max(), d.max())) * 1.1
        ax.plot([0, top], [0, top], color="k", lw=0.8, ls="--")
        ax.legend(fontsize=7)
    ax.set_xlabel("bound: speed x tau (ln(step / 10 %) - 1) + margin, m")
    ax.set_ylabel("transition distance (until within ±10 %), m")
    ax.set_title(f"{len(steps)} rate steps", fontsize=8)
    ax = axes[0, 2]
    p = doc.get("product") or {}
    names = [f"uniform {_num(p.get('uniform_rate_lpha')):.1f} L/ha", "prescribed", "applied (pump)"]
    vals = [_num(p.get("uniform_l")), _num(p.get("prescribed_l")), _num(p.get("applied_l"))]
    ax.bar(names, vals, color=["#9e9e9e", "#1f77b4", "#2ca02c"])
    for i, v in enumerate(vals):
        ax.text(i, v, f"{v:.3g} L", ha="center", va="bottom", fontsize=8)
    ax.set_ylabel("litres over the rows' planned stretches")
    ax.set_title(f"saving against the uniform rate: {_num(p.get('saving_l')):.3g} L "
                 f"({_num(p.get('saving_pct')):.1f} %)", fontsize=8)
    ax.tick_params(axis="x", labelsize=7)
    set_title(fig, data, "as applied: errors, transitions, product")
    return png_bytes(fig)
