"""``plan rows`` with a dose: the canopy of the planned rows segment by segment and the rate of every segment
(:class:`~vinecli.rows.segment_rates.SegmentRates`), written as ``OUT-stem.rates.json`` and
``OUT-stem.rates.geojson`` beside the plan (docs/dose.md).

The canopy: a DSM source is measured at its own resolution on the planned rows; a world gives the segments
``world build`` measured (``canopy_segments.json``) when the plan flies its rows, else they are measured on its
height grid; a flat world without a canopy has plain segments (a rate or a map only).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vinecli.errors import InputError, check_range
from vinecli.gis.georef import Georef
from vinecli.gis.write import LocalFeature, write_features
from vinecli.inputs import note_input
from vinecli.outputs import json_text, write_text_atomic
from vinecli.rows.canopy_segments import CanopySegments, Sampling, plain_segments, segment_canopy
from vinecli.rows.detect import Polyline
from vinecli.rows.dose_units import DoseExpr
from vinecli.rows.segment_rates import SegmentRates, segment_rates

if TYPE_CHECKING:
    from vinecli.rows.source import DsmRows
    from vinecli.terrain.grid import TerrainGrid

__all__ = ["CanopySource", "DoseOptions", "mission_dose", "plan_segment_rates", "rates_paths", "write_rates"]


@dataclass(frozen=True)
class DoseOptions:
    """The dose options of ``plan rows``: one of ``rate_lpha`` (L/ha), ``lwa_dose_l`` (L per 10 000 m² LWA),
    ``trv_dose_l`` (L per 10 000 m³ TRV) or ``prescription`` (a map: ``rate_column``, ``default_rate_lpha``,
    ``rate_units``, ``layer``); ``sides`` treated; ``segment_m`` (1-5 m) and ``foliage_base_m`` of the canopy."""

    rate_lpha: float | None = None
    lwa_dose_l: float | None = None
    trv_dose_l: float | None = None
    sides: int = 2
    prescription: Path | None = None
    rate_column: str | None = None
    default_rate_lpha: float | None = None
    rate_units: str = "L/ha"
    layer: str | None = None
    segment_m: float = 2.0
    foliage_base_m: float = 0.0

    @property
    def given(self) -> bool:
        return self.dose_count > 0

    @property
    def dose_count(self) -> int:
        return sum(v is not None for v in (self.rate_lpha, self.lwa_dose_l, self.trv_dose_l, self.prescription))

    def check(self) -> None:
        """One dose at most, each value in its range (SpecError naming the option, exit 2)."""
        if self.dose_count > 1:
            raise InputError("give one of --rate, --dose-lwa, --dose-trv or --prescription")
        for opt, v in (("--rate", self.rate_lpha), ("--dose-lwa", self.lwa_dose_l), ("--dose-trv", self.trv_dose_l)):
            if v is not None:
                check_range(opt, v, 0.0, 10_000.0, open_lo=True)
        if self.default_rate_lpha is not None:
            check_range("--default-rate", self.default_rate_lpha, 0.0, 10_000.0)
        check_range("--segment", self.segment_m, 1.0, 5.0)
        check_range("--foliage-base", self.foliage_base_m, 0.0, 20.0)
        if self.sides not in (1, 2):
            raise InputError(f"--sides {self.sides}: use 1 or 2")
        if self.prescription is not None:
            note_input(self.prescription / "TASKDATA.XML" if self.prescription.is_dir() else self.prescription,
                       "prescription map")

    def dose(self) -> DoseExpr | None:
        if self.rate_lpha is not None:
            return DoseExpr("rate", self.rate_lpha, self.sides)
        if self.lwa_dose_l is not None:
            return DoseExpr("lwa", self.lwa_dose_l, self.sides)
        if self.trv_dose_l is not None:
            return DoseExpr("trv", self.trv_dose_l, self.sides)
        return None


def rates_paths(out: Path) -> list[Path]:
    """``OUT-stem.rates.json`` and ``OUT-stem.rates.geojson`` beside the plan ``out``."""
    return [out.with_name(f"{out.stem}.rates.json"), out.with_name(f"{out.stem}.rates.geojson")]


@dataclass(frozen=True)
class CanopySource:
    """Where the planned rows' canopy is measured: on a DSM (``dsm_path``, its rows ``dsm``), from a world's
    canopy segments (``world_dir``; ``world_rows``: the rows planned are the world's own), or on a world's height
    grid (``grid``); none: plain segments (no canopy measured)."""

    dsm_path: Path | None = None
    dsm: DsmRows | None = None
    world_dir: Path | None = None
    world_rows: bool = False
    grid: TerrainGrid | None = None


def _canopy(opts: DoseOptions, rows: list[Polyline], spacing: float, src: CanopySource) -> CanopySegments:
    dsm_path, dsm, world_dir, world_rows, grid = src.dsm_path, src.dsm, src.world_dir, src.world_rows, src.grid
    if dsm is not None and dsm_path is not None:
        from vinecli.rows.dsm_canopy import read_heights

        h = read_heights(dsm_path, dsm)
        return segment_canopy(h, rows, spacing_m=spacing, base_m=opts.foliage_base_m, segment_m=opts.segment_m,
                              sampling=Sampling(step_m=min(0.1, max(abs(h.dx), 0.02))))
    if world_dir is not None and world_rows:
        from vinecli.world.canopy_files import load_canopy_segments

        segs = load_canopy_segments(world_dir)
        if segs is not None:
            return segs
    if grid is not None:
        return segment_canopy(grid.heights, rows, spacing_m=spacing, base_m=opts.foliage_base_m,
                              segment_m=opts.segment_m)
    return plain_segments(rows, spacing, opts.segment_m)


def plan_segment_rates(opts: DoseOptions, rows: list[Polyline], georef: Georef,
                       source: CanopySource = CanopySource(), spacing_m: float | None = None) -> SegmentRates:
    """The rates of the planned ``rows`` (local m of ``georef``) for the dose of ``opts``, the canopy measured
    from ``source`` (InputError, exit 2, for a map that does not fit, or a dose per LWA/TRV without a canopy)."""
    from vinecli.spray.canopy import row_spacing

    spacing = spacing_m if spacing_m is not None else row_spacing(rows)
    if not (spacing is not None and math.isfinite(spacing) and spacing > 0):
        raise InputError("a dose needs the row spacing: plan at least two rows")
    canopy = _canopy(opts, rows, spacing, source)
    if opts.prescription is not None:
        from vinecli.gis.prescription import read_prescription

        m = read_prescription(opts.prescription, georef, rows, column=opts.rate_column,
                              default_lpha=opts.default_rate_lpha, layer=opts.layer, units=opts.rate_units)
        return segment_rates(canopy, rate_map=m.rates, prescription=m.summary(), rows=rows)
    dose = opts.dose()
    assert dose is not None
    try:
        return segment_rates(canopy, dose=dose, rows=rows)
    except ValueError as exc:
        raise InputError(str(exc)) from None


def write_rates(out: Path, rates: SegmentRates, georef: Georef) -> list[Path]:
    """Write the rates beside the plan ``out`` (:func:`rates_paths`)."""
    js, gj = rates_paths(out)
    write_text_atomic(js, json_text(rates.to_dict()))
    feats = [LocalFeature("LineString", [g.start_enu, g.end_enu],
                          {"row": g.row, "s0_m": g.s0_m, "s1_m": g.s1_m, "rate_lpha": round(g.rate_lpha, 3),
                           "gap": int(g.gap), "wall_height_m": round(g.wall_height_m, 3), "width_m": round(g.width_m, 3),
                           "lwa_m2pha": round(g.lwa_m2pha, 1), "trv_m3pha": round(g.trv_m3pha, 1)})
             for g in rates.segments]
    write_features(gj, feats, georef, layer="rates")
    return [js, gj]


def mission_dose(opts: DoseOptions, *, world_rows: int | None) -> dict[str, Any]:
    """The spray phase fields that carry ``opts``'s dose into ``plan rows --mission``: ``rate_lpha``, the
    ``prescription`` (its path absolute), or a canopy dose (``lwa_dose_l``/``trv_dose_l``, ``sides``,
    ``segment_m``) over the world's rows by index (``world_rows``: how many; None when the rows are not a world's
    own: InputError, the run could not find their canopy)."""
    if opts.rate_lpha is not None:
        return {"rate_lpha": opts.rate_lpha}
    if opts.prescription is not None:
        return {"prescription": {"path": str(opts.prescription.resolve()), "column": opts.rate_column,
                                 "layer": opts.layer, "default_lpha": opts.default_rate_lpha, "units": opts.rate_units}}
    what = "--dose-lwa" if opts.lwa_dose_l is not None else "--dose-trv"
    if world_rows is None:
        raise InputError(f"--mission with {what}: a run doses on a world's canopy segments (world build); plan on "
                         "a world with its own rows (not a DSM, not --detect) or give --rate / --prescription")
    key = "lwa_dose_l" if opts.lwa_dose_l is not None else "trv_dose_l"
    return {key: opts.lwa_dose_l if opts.lwa_dose_l is not None else opts.trv_dose_l, "sides": opts.sides,
            "segment_m": opts.segment_m, "rows": list(range(world_rows))}
