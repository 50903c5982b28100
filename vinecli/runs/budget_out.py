"""The spray budget of a run (docs/budget.md): ``budget.json``, ``canopy_deposit.tif``, ``drift_curve.csv``, metrics.

``budget.json`` (schema ``vinecli.budget/1``): ``fractions`` of the emitted volume (canopy,
ground_in_field, ground_off_field, airborne_out, evaporated; they sum to 1 within ``balance_error``),
``volumes_l``, ``drift_curve`` [{distance_m, percent_of_applied}] downwind of the last row, ``drift``
(how the curve was read), ``conditions`` (wind, drop spectrum, canopy, air, applied rate), ``rows``
(per row: the canopy deposit and its leaf area, µL/cm² and µL/cm² per applied L/ha, and where the
spray released over that row went), ``maps`` (the rasterised totals) and ``metrics``.

``canopy_deposit.tif`` (the deposition grid's cells over the hedges, georeferenced as ``deposition.tif``): band 1 canopy
deposit per one-sided leaf area, µL/cm² (nodata off the hedges); band 2 the canopy deposit per ground
area, L/ha. ``deposition.tif`` stays the spray pattern as it reaches the canopy top and the ground.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vinecli.missions.budget_metrics import budget_metrics
from vinecli.runs.deposition_out import NODATA, clean_json, write_grid_tif
from vinecli.spray.budget import FRACTIONS, BudgetConfig, SprayBudget, spray_budget
from vinecli.spray.deposit_grid import rasterise

if TYPE_CHECKING:
    from vinecli.sim.spray_deposit import DepositionResult

__all__ = ["BUDGET_JSON", "CANOPY_TIF", "DRIFT_CSV", "BudgetOutputs", "evaluate_budget", "write_budget"]

BUDGET_JSON = "budget.json"
CANOPY_TIF = "canopy_deposit.tif"
DRIFT_CSV = "drift_curve.csv"
UL_PER_CM2_PER_L_PER_M2 = 100.0  # 1 L/m² = 1e6 µL / 1e4 cm²


@dataclass
class BudgetOutputs:
    """A run's budget, its maps (L per cell; leaf area m² per cell) on the deposition grid's cells over the hedges,
    and its documents."""

    budget: SprayBudget
    grid: Any  # GridSpec of the maps: the deposition grid's cells around the hedges
    canopy_l: np.ndarray
    leaf_m2: np.ndarray
    doc: dict[str, Any]
    metrics: dict[str, float]


def _hedge_cells(grid: Any, canopy: Any) -> np.ndarray:
    """(ny, nx) one-sided leaf area (m²) of the hedges above each cell, splatted like the canopy deposit
    (:data:`~vinecli.spray.budget.ACROSS` points across each hedge, every half cell along it) so both maps
    share their cells."""
    from vinecli.spray.budget import ACROSS

    if canopy is None:
        return np.zeros((grid.ny, grid.nx))
    xs, ys, ws = [], [], []
    for h in canopy.hedges:
        if h.width_m <= 0 or h.row >= len(canopy.rows) or len(canopy.rows[h.row]) < 2:
            continue
        pts = np.asarray(canopy.rows[h.row], dtype=np.float64)
        for (ax, ay), (bx, by) in zip(pts[:-1], pts[1:], strict=True):
            seg = float(np.hypot(bx - ax, by - ay))
            if seg <= 0:
                continue
            n = max(1, int(np.ceil(seg / (0.5 * grid.cell))))
            t = (np.arange(n) + 0.5) / n
            nx, ny = -(by - ay) / seg, (bx - ax) / seg
            for c in ACROSS:
                xs.append(ax + t * (bx - ax) + c * h.width_m * nx)
                ys.append(ay + t * (by - ay) + c * h.width_m * ny)
                ws.append(np.full(n, h.lad_m2m3 * h.depth_m * h.width_m * seg / (n * len(ACROSS))))
    if not xs:
        return np.zeros((grid.ny, grid.nx))
    return rasterise(grid, np.concatenate(xs), np.concatenate(ys), np.concatenate(ws))[0]


def _release_rows(parcels: Any, group: np.ndarray, rows: list[Any]) -> np.ndarray:
    """Per parcel: the row its emission group sprayed (the row nearest to where the group's cone and wake plume
    landed, the volume-weighted mean of its primaries; the nozzle path point where none landed). A pass planned
    upwind of its row in a crosswind (swath displacement) is flown nearer the upwind neighbour but sprays its row."""
    path_xy = np.asarray(parcels.path_xy)
    if not rows or path_xy.size == 0 or group.size == 0:
        return np.full(group.size, -1, dtype=np.int64)
    from vinecli.geometry import point_polyline_distance

    n = int(getattr(parcels, "primaries", 0))
    g, w = np.asarray(parcels.group[:n], dtype=np.int64), np.asarray(parcels.vol[:n], dtype=float)
    vol = np.bincount(g, weights=w, minlength=len(path_xy))
    at = path_xy[:, :2].astype(float)
    landed = vol > 0.0
    for k, c in enumerate((parcels.x, parcels.y)):
        at[landed, k] = np.bincount(g, weights=w * np.asarray(c[:n]), minlength=len(path_xy))[landed] / vol[landed]
    d = np.stack([point_polyline_distance(at[:, 0], at[:, 1], [r]) for r in rows])
    return np.argmin(d, axis=0)[group]


def evaluate_budget(dep: DepositionResult, world: Any, rows_all: list[Any], applied_lpha: float,
                    config: BudgetConfig | None = None) -> BudgetOutputs:
    """The budget of one run's deposition (:class:`~vinecli.sim.spray_deposit.DepositionResult`) over ``world``."""
    from vinecli.spray.canopy import hedge_window, row_spacing

    config = config or BudgetConfig()
    canopy = world.canopy_model() if hasattr(world, "canopy_model") else None
    geo = dep.geometry
    p = dep.parcels
    b = spray_budget(p, geo.diam_m, geo.v_t, canopy, rows_all, row_spacing(rows_all), applied_lpha, dep.wind_xy,
                     getattr(world, "air", None), config, float(world.gravity))
    g = hedge_window(dep.grid, canopy)
    cx, cy, cv = b.canopy_points
    canopy_l, off = rasterise(g, cx, cy, cv)
    leaf = _hedge_cells(g, canopy)
    metrics = budget_metrics(b, canopy, applied_lpha)
    release = _release_rows(p, b.group, rows_all)
    doc = {**_document(b, dep, world, canopy, applied_lpha, config, release),
           "maps": {"canopy_on_grid_l": float(canopy_l.sum()), "canopy_off_grid_l": off, "grid": g.to_dict()},
           "metrics": metrics}
    return BudgetOutputs(b, g, canopy_l, leaf, doc, metrics)


def _document(b: SprayBudget, dep: DepositionResult, world: Any, canopy: Any, applied: float, config: BudgetConfig,
              release: np.ndarray) -> dict[str, Any]:
    """budget.json but its ``maps`` and ``metrics`` (which follow)."""
    rows_doc = []
    n_rows = len(canopy.rows) if canopy is not None else len(getattr(world, "vine_rows_enu", []) or [])
    for i in range(n_rows):
        mine = release == i
        released = float(b.parts[:, mine].sum())
        entry: dict[str, Any] = {"row": i, "released_l": released,
                                 "released": {k: (float(b.parts[j, mine].sum()) / released if released > 0 else 0.0)
                                              for j, k in enumerate(FRACTIONS)}}
        if canopy is not None and i < len(b.row_canopy_l):
            area = canopy.leaf_area_m2(i)
            dep_ul = UL_PER_CM2_PER_L_PER_M2 * b.row_canopy_l[i] / area if area > 0 else math.nan
            entry.update(canopy_l=float(b.row_canopy_l[i]), leaf_area_m2=area, deposit_ulpcm2=dep_ul,
                         deposit_ulpcm2_per_lpha=dep_ul / applied if applied > 0 else math.nan)
        rows_doc.append(entry)
    sp = dep.sprayer or {}
    return {
        "schema": "vinecli.budget/1",
        "units": {"volume": "L", "fraction": "of the emitted volume", "drift": "% of the applied rate",
                  "deposit": "µL/cm² of one-sided leaf area", "frame": "world ENU"},
        "fractions": b.fractions, "balance_error": b.balance_error,
        "volumes_l": {"emitted": b.emitted_l, "canopy": b.canopy_l, "ground_in_field": b.ground_in_field_l,
                      "ground_off_field": b.ground_off_field_l, "airborne_out": b.airborne_out_l,
                      "evaporated": b.evaporated_l},
        "drift_curve": b.drift,
        "drift": {"reference": "last row downwind (its line), middle half of its length", "band_m": config.drift_band_m,
                  "downwind_normal_enu": b.downwind_normal, "calm": b.calm, "last_rows": b.last_rows,
                  "domain_m": config.domain_m},
        "conditions": {
            "wind_mean_enu_mps": list(dep.wind_xy), "applied_lpha": applied,
            "drop_spectrum": {**(sp.get("droplets") or {}), "class_diameters_um": sp.get("class_diameters_um")},
            "canopy": canopy.to_dict() if canopy is not None else None,
            "air": ({"temperature_c": world.air[0], "relative_humidity_pct": world.air[1]}
                    if getattr(world, "air", None) else None),
            "evaporation": b.evaporation,
        },
        "rows": rows_doc,
    }


def write_budget(out_dir: Path, out: BudgetOutputs, dep: DepositionResult, world: Any, crs: Any) -> None:
    """Write ``budget.json``, ``canopy_deposit.tif`` and ``drift_curve.csv`` into ``out_dir``."""
    g = out.grid
    cell_area = g.cell * g.cell
    hedge = (out.leaf_m2 > 0) | (out.canopy_l > 0)  # a cell with a deposit and no leaves: the hedges' edge
    with np.errstate(invalid="ignore", divide="ignore"):
        per_leaf = np.where(out.leaf_m2 > 1e-9 * cell_area, UL_PER_CM2_PER_L_PER_M2 * out.canopy_l / out.leaf_m2,
                            np.nan)
    on_canopy = np.where(hedge, out.canopy_l * 1e4 / cell_area, np.nan)
    transform = write_grid_tif(out_dir / CANOPY_TIF, g, [per_leaf, on_canopy],
                               ["canopy deposit µL/cm² of leaf area", "canopy deposit L/ha"],
                               world, crs, {"UNITS": "µL/cm², L/ha", "QUANTITY": "canopy deposit"})
    doc = {**out.doc, "geotiff": {"file": CANOPY_TIF, "bands": ["canopy_ulpcm2", "canopy_lpha"],
                                  "crs": crs.to_string() if crs is not None else None,
                                  "transform": list(transform)[:6], "nodata": NODATA},
           "drift_csv": DRIFT_CSV}
    (out_dir / BUDGET_JSON).write_text(json.dumps(clean_json(doc, None), indent=1, allow_nan=False), encoding="utf-8")
    with open(out_dir / DRIFT_CSV, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["distance_m", "percent_of_applied"])
        for pt in out.budget.drift:
            v = pt["percent_of_applied"]
            w.writerow([f"{pt['distance_m']:g}", f"{v:.6g}" if math.isfinite(v) else ""])
