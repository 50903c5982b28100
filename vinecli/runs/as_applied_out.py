"""The as-applied outputs of a dosed run (docs/dose.md §6), written into the run directory:

* ``as_applied.json`` (schema ``vinecli.as_applied/1``): the summary (``summary.json`` ``as_applied``), every
  segment (prescribed, pump and deposit rates, errors), every rate step (transition distance, bound), every gap,
  the 1 Hz log and the rates of every 0.1 m bin along the rows (``bins``);
* ``as_applied.gpkg``: GeoPackage points (EPSG:4326), layer ``per_second`` (position once a second of the spray
  phase: t_s, row, s_m, prescribed_lpha, pump_lpha, flow_lps, speed_mps) and layer ``per_segment`` (each
  segment's midpoint: row, s0_m, s1_m, gap, prescribed_lpha, pump_lpha, deposit_lpha, pump_error_pct,
  deposit_error_pct); ``pump_lpha`` is what the pump delivered (flow / (ground speed x track width)),
  ``deposit_lpha`` what reached the canopy band on the deposition map; NaN where not known;
* ``as_applied.tif``: float32 bands prescribed_lpha, pump_lpha, deposit_lpha, pump_error_pct on the deposition
  grid, georeferenced as ``deposition.tif`` (the DSM's CRS); each segment fills its row's strip (± half the row
  spacing); nodata -9999;
* ``dose_map/``: the prescription, as-applied and error layers as small GeoJSON and PNG overlays for a web map
  (:mod:`vinecli.runs.dose_layers`);
* ``as_applied_taskdata/``: an ISO 11783-10 TimeLog when the prescription was ISO-XML
  (:mod:`vinecli.gis.isoxml_timelog`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.gis.canopy_out import segment_strip
from vinecli.gis.write import LocalFeature, write_layers
from vinecli.missions.as_applied import AsApplied, DoseRun
from vinecli.rows.segment_rates import SegmentRates

__all__ = ["AS_APPLIED_GPKG", "AS_APPLIED_JSON", "AS_APPLIED_TIF", "TASKDATA_DIR", "DoseOutputs"]

AS_APPLIED_JSON = "as_applied.json"
AS_APPLIED_GPKG = "as_applied.gpkg"
AS_APPLIED_TIF = "as_applied.tif"
TASKDATA_DIR = "as_applied_taskdata"
TIF_BANDS = ("prescribed_lpha", "pump_lpha", "deposit_lpha", "pump_error_pct")


def _num(v: Any) -> float:
    return float(v) if isinstance(v, (int, float)) and math.isfinite(v) else math.nan


def _pct(v: Any) -> float:
    return round(100.0 * v, 3) if isinstance(v, (int, float)) and math.isfinite(v) else math.nan


@dataclass
class DoseOutputs:
    """A run's as-applied figures and what writing them needs: the rates, the phase's :class:`DoseRun`, the
    summary document and the deposition grid (None: no deposition)."""

    aa: AsApplied
    rates: SegmentRates
    run: DoseRun
    summary: dict[str, Any]
    grid: Any

    def features(self) -> dict[str, list[LocalFeature]]:
        """The two point layers of ``as_applied.gpkg``."""
        per_second = [LocalFeature("Point", [(p["x"], p["y"])], {
            "t_s": round(p["t_s"], 3), "row": p["row"], "s_m": _num(p["s_m"]), "prescribed_lpha": _num(p["prescribed_lpha"]),
            "pump_lpha": _num(p["pump_lpha"]), "flow_lps": p["flow_lps"], "speed_mps": round(p["speed_mps"], 4)})
            for p in self.aa.per_second]
        per_segment = [LocalFeature("Point", [g["mid_enu"]], {
            "row": g["row"], "s0_m": g["s0_m"], "s1_m": g["s1_m"], "gap": int(g["gap"]),
            "prescribed_lpha": g["prescribed_lpha"], "pump_lpha": _num(g["pump_lpha"]),
            "deposit_lpha": _num(g["deposit_lpha"]), "pump_error_pct": _pct(g["pump_error"]),
            "deposit_error_pct": _pct(g["deposit_error"])}) for g in self.aa.segments]
        return {"per_second": per_second, "per_segment": per_segment}

    def doc(self) -> dict[str, Any]:
        """``as_applied.json``."""
        from vinecli.runs.deposition_out import clean_json

        bins = [{"row": k, "s_m": b["s_m"], "prescribed_lpha": b["prescribed"], "pump_lpha": b["pump"],
                 "deposit_lpha": b["deposit"]} for k, b in enumerate(self.aa.bins)]
        return clean_json({"schema": "vinecli.as_applied/1",
                           "units": {"rate": "L/ha of ground", "s": "m along the row from its first point",
                                     "enu": "m, world ENU", "error": "applied / prescribed - 1"},
                           "summary": self.summary, **self.aa.doc(), "per_second": self.aa.per_second,
                           "bins": bins}, digits=4)

    def write(self, out_dir: Path, world: Any, world_dir: Path, summary: dict[str, Any]) -> None:
        """Write every output into ``out_dir`` (module docstring) and put :attr:`summary` into the run's ``summary``
        (``as_applied``; summary.json is written after)."""
        summary["as_applied"] = self.summary
        from vinecli.gis.georef import world_dir_georef
        from vinecli.runs.deposition_out import dsm_crs
        from vinecli.runs.dose_layers import write_dose_layers

        (out_dir / AS_APPLIED_JSON).write_text(json.dumps(self.doc(), indent=1, allow_nan=False), encoding="utf-8")
        georef = world_dir_georef(world_dir)
        write_layers(out_dir / AS_APPLIED_GPKG, self.features(), georef, spatial_index=False)
        self.write_tif(out_dir / AS_APPLIED_TIF, world, dsm_crs(world_dir))
        write_dose_layers(out_dir, self.aa.segments, self.rates.spacing_m, georef)
        pr = self.rates.prescription or {}
        if str(pr.get("kind", "")).startswith("isoxml"):
            from vinecli.gis.isoxml_timelog import write_timelog

            write_timelog(out_dir / TASKDATA_DIR, Path(str(pr["file"])), self.aa.per_second, georef)

    def write_tif(self, path: Path, world: Any, crs: Any) -> None:
        """``as_applied.tif`` on the deposition grid (a 0.1 m grid over the rows without one)."""
        from rasterio.features import rasterize
        from rasterio.transform import Affine
        from shapely.geometry import Polygon

        from vinecli.runs.deposition_out import write_grid_tif
        from vinecli.spray.deposit_grid import GridSpec

        segs = self.aa.segments
        half = 0.5 * self.rates.spacing_m
        strips = [segment_strip(g["start_enu"], g["end_enu"], half) for g in segs]
        g = self.grid
        if g is None:
            pts = np.asarray([p for s in strips for p in s]) if strips else np.zeros((1, 2))
            lo = np.floor(pts.min(axis=0)) - 1.0
            n = np.ceil((pts.max(axis=0) + 1.0 - lo) / 0.1).astype(int) + 1
            g = GridSpec(float(lo[0]), float(lo[1]), 0.1, int(n[0]), int(n[1]))
        pix = Affine(g.cell, 0.0, g.x0, 0.0, -g.cell, g.y0 + g.ny * g.cell)  # row 0 north
        label = rasterize(((Polygon(s), k + 1) for k, s in enumerate(strips)), out_shape=(g.ny, g.nx), transform=pix,
                          fill=0, dtype="int32") if strips else np.zeros((g.ny, g.nx), dtype=np.int32)
        table = np.full((len(TIF_BANDS), len(segs) + 1), np.nan)
        for k, s in enumerate(segs, start=1):
            table[:, k] = (s["prescribed_lpha"], _num(s["pump_lpha"]), _num(s["deposit_lpha"]), _pct(s["pump_error"]))
        bands = [np.flipud(table[b][label]) for b in range(len(TIF_BANDS))]  # row 0 south, as write_grid_tif takes
        write_grid_tif(path, g, bands, list(TIF_BANDS), world, crs,
                       {"UNITS": "L/ha (error: %)", "QUANTITY": "as-applied spray rate per segment",
                        "PUMP_LPHA": "delivered flow / (ground speed x track width)",
                        "DEPOSIT_LPHA": "deposit on the canopy band (deposition map)"})

