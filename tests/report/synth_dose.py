"""A synthetic as-applied log (``as_applied.json``, schema ``vinecli.as_applied/1``, as vinecli.runs.as_applied_out
writes it) for a copy of the synthetic spray run: every vine row cut into 2 m segments, two prescription zones (20
L/ha south of y = 0, 30 L/ha north), the pump within a few % of each segment's rate except one segment 25 % over
(:data:`HOT`), and one gap. Known truth for the report's dose layers and figures 26/27."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .synth_runs import ROW_Y, ROWS_X

SEGMENT_M = 2.0
SPACING_M = 2.5
HOT = (2, 9)  # (row, segment index along it): the pump 25 % over its target
GAP = (4, 3)  # a gap (missing vines): kept closed


def _target(y: float) -> float:
    return 20.0 if y < 0 else 30.0


def as_applied_doc() -> dict[str, Any]:
    """The document (module docstring)."""
    segs, bins = [], []
    n = int((ROW_Y[1] - ROW_Y[0]) / SEGMENT_M)
    for r, x in enumerate(ROWS_X):
        b: dict[str, list[float]] = {"s_m": [], "prescribed_lpha": [], "pump_lpha": [], "deposit_lpha": []}
        for k in range(n):
            y0, y1 = ROW_Y[0] + k * SEGMENT_M, ROW_Y[0] + (k + 1) * SEGMENT_M
            gap = (r, k) == GAP
            target = 0.0 if gap else _target(0.5 * (y0 + y1))
            pump = target * (1.25 if (r, k) == HOT else 1.0 + 0.03 * math.sin(k + r))
            dep = 0.9 * pump
            segs.append({
                "segment": len(segs), "row": r, "s0_m": k * SEGMENT_M, "s1_m": (k + 1) * SEGMENT_M, "gap": gap,
                "mid_enu": [x, 0.5 * (y0 + y1)], "wall_height_m": 0.0 if gap else 1.2 + 0.3 * math.cos(k),
                "width_m": 0.0 if gap else 0.6, "lwa_m2pha": 0.0 if gap else 2e4 * (1.2 + 0.3 * math.cos(k)) / SPACING_M,
                "start_enu": [x, y0], "end_enu": [x, y1], "prescribed_lpha": target, "pump_lpha": pump,
                "deposit_lpha": dep, "pump_error": pump / target - 1.0 if target else None,
                "deposit_error": dep / target - 1.0 if target else None,
                "pump_in_band": bool(abs(pump - target) <= 0.1 * target) if target else pump <= 0.0})
            for s in np.arange(k * SEGMENT_M + 0.05, (k + 1) * SEGMENT_M, 0.1):
                b["s_m"].append(float(s))
                b["prescribed_lpha"].append(target)
                b["pump_lpha"].append(pump)
                b["deposit_lpha"].append(dep)
        bins.append({"row": r, **b})
    zones = []
    for name, north in (("20 L/ha", False), ("30 L/ha", True)):
        mine = [g for g in segs if not g["gap"] and (g["mid_enu"][1] >= 0) == north]
        p = sum(g["prescribed_lpha"] for g in mine)
        zones.append({"zone": name, "length_m": SEGMENT_M * len(mine), "prescribed_l": p * SEGMENT_M * SPACING_M / 1e4,
                      "pump_error": sum(g["pump_lpha"] for g in mine) / p - 1.0,
                      "deposit_error": sum(g["deposit_lpha"] for g in mine) / p - 1.0,
                      "pump_in_band": float(np.mean([g["pump_in_band"] for g in mine]))})
    presc = sum(g["prescribed_lpha"] for g in segs) * SEGMENT_M * SPACING_M / 1e4
    applied = sum(g["pump_lpha"] for g in segs) * SEGMENT_M * SPACING_M / 1e4
    uniform = 30.0 * SEGMENT_M * SPACING_M / 1e4 * sum(not g["gap"] for g in segs)
    summary = {"dose": None, "prescription": {"file": "zones.gpkg", "kind": "zones", "zones": 2}, "spacing_m": SPACING_M,
               "tolerance": 0.1, "zones": zones,
               "in_band_fraction": float(np.mean([g["pump_in_band"] for g in segs if not g["gap"]])),
               "in_band_fraction_deposit": 0.0}
    return {"schema": "vinecli.as_applied/1", "summary": summary, "tolerance": 0.1, "metrics": {},
            "product": {"uniform_rate_lpha": 30.0, "uniform_l": uniform, "prescribed_l": presc, "applied_l": applied,
                        "saving_l": uniform - applied, "saving_pct": 100 * (1 - applied / uniform)},
            "zones": zones, "transitions": [], "gaps": [], "segments": segs, "per_second": [], "bins": bins}


def write_as_applied(run_dir: Path) -> dict[str, Any]:
    """Write ``as_applied.json`` into ``run_dir``; returns the document."""
    doc = as_applied_doc()
    (run_dir / "as_applied.json").write_text(json.dumps(doc), encoding="utf-8")
    return doc
