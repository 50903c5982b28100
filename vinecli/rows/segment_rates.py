"""THE bridge from a dose to flying it: the prescribed rate along every row, segment by segment (docs/dose.md).

:func:`segment_rates` turns canopy segments (:mod:`vinecli.rows.canopy_segments`) and a dose - a rate, a label
dose per LWA or per TRV (:mod:`vinecli.rows.dose_units`), or a prescription map (any callable
``rate(x, y) -> L/ha``, :class:`vinecli.gis.prescription.RateMap`) - into :class:`SegmentRates`:

* a gap gets 0 L/ha; a canopy segment its dose converted on its own wall height, width and cover (a thin or
  patchy canopy gets less), or the map's rate;
* with a map, canopy segments are cut where the map's rate changes (pieces shorter than ``MIN_PIECE_M`` join
  the one before and take its rate), so that each segment has one rate, the map's;
* rates are L of spray liquid per ha of ground; a metre of row stands for ``spacing_m`` m² of it:
  ``litres per m of row = rate x spacing / 10 000``.

``plan rows`` writes it as ``OUT-stem.rates.json`` (schema ``vinecli.segment_rates/1``); a run with a dose
phase builds it at set-up (:mod:`vinecli.sim.dose_setup`). Its ``summary`` states the product against a
uniform rate over the same rows (gaps included, as a sprayer without canopy sensing applies it).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.rows.canopy_segments import CanopySegment, CanopySegments, row_stations
from vinecli.rows.dose_units import HA_M2, DoseExpr, rate_from_lwa_dose, rate_from_trv_dose

__all__ = ["MIN_PIECE_M", "RATES_SCHEMA", "RateSegment", "SegmentRates", "segment_rates"]

RATES_SCHEMA = "vinecli.segment_rates/1"
#: a piece of canopy between two rate changes of a map shorter than this joins the piece before, m
MIN_PIECE_M = 0.3
#: along-row sampling of a map, m
MAP_STEP_M = 0.1

RateFn = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class RateSegment:
    """One stretch of one row at one rate: ``row`` (index into the plan's rows), ``s0_m``..``s1_m`` along it (m
    from its first point), ENU end points (m), ``rate_lpha`` (L/ha of ground; 0 = sections closed), ``gap``,
    and the canopy it was computed from (wall height, width m; cover 0-1; LWA m²/ha both sides; TRV m³/ha)."""

    row: int
    s0_m: float
    s1_m: float
    start_enu: tuple[float, float]
    end_enu: tuple[float, float]
    rate_lpha: float
    gap: bool
    wall_height_m: float
    width_m: float
    cover: float
    lwa_m2pha: float
    trv_m3pha: float

    @property
    def length_m(self) -> float:
        return self.s1_m - self.s0_m

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["start_enu"], d["end_enu"] = list(self.start_enu), list(self.end_enu)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RateSegment:
        kw = {k: d[k] for k in cls.__dataclass_fields__}
        kw["start_enu"], kw["end_enu"] = tuple(d["start_enu"]), tuple(d["end_enu"])
        return cls(**kw)


@dataclass(frozen=True)
class SegmentRates:
    """Every row's rate segments in order (row, then along it); ``dose`` as asked (None: a map), the map's
    ``prescription`` summary, the rows' ``spacing_m``, the ``uniform_rate_lpha`` the summary compares with."""

    segments: tuple[RateSegment, ...]
    spacing_m: float
    dose: DoseExpr | None
    prescription: dict[str, Any] | None
    uniform_rate_lpha: float
    canopy_source: str

    def for_row(self, row: int) -> list[RateSegment]:
        return [g for g in self.segments if g.row == row]

    def rate_at(self, row: int, s_m: float) -> float:
        """The rate (L/ha) at ``s_m`` m along row ``row``; 0 off its segments."""
        for g in self.for_row(row):
            if g.s0_m <= s_m < g.s1_m or (s_m == g.s1_m and g is self.for_row(row)[-1]):
                return g.rate_lpha
        return 0.0

    def litres(self) -> float:
        """Spray liquid the segments take, L (rate x length x spacing / 10 000)."""
        return float(sum(g.rate_lpha * g.length_m for g in self.segments) * self.spacing_m / HA_M2)

    def summary(self) -> dict[str, Any]:
        sprayed = [g for g in self.segments if g.rate_lpha > 0]
        length = sum(g.length_m for g in self.segments)
        w = np.array([g.length_m for g in sprayed])
        r = np.array([g.rate_lpha for g in sprayed])
        uniform_l = self.uniform_rate_lpha * length * self.spacing_m / HA_M2
        used = self.litres()
        return {"segments": len(self.segments), "rows": len({g.row for g in self.segments}),
                "dose": self.dose.label() if self.dose is not None else None,
                "prescription": self.prescription, "canopy_source": self.canopy_source,
                "row_length_m": length, "sprayed_length_m": float(w.sum()),
                "gap_length_m": float(sum(g.length_m for g in self.segments if g.gap)),
                "rate_min_lpha": float(r.min()) if r.size else 0.0,
                "rate_mean_lpha": float(np.average(r, weights=w)) if r.size and w.sum() > 0 else 0.0,
                "rate_max_lpha": float(r.max()) if r.size else 0.0,
                "litres": used, "uniform_rate_lpha": self.uniform_rate_lpha, "uniform_litres": uniform_l,
                "saving_l": uniform_l - used, "saving_pct": 100.0 * (uniform_l - used) / uniform_l if uniform_l > 0 else 0.0}

    def to_dict(self) -> dict[str, Any]:
        dose = None if self.dose is None else {"kind": self.dose.kind, "value": self.dose.value,
                                               "units": self.dose.units, "sides": self.dose.sides}
        return {"schema": RATES_SCHEMA, "units": {"rate": "L/ha of ground", "s": "m along the row from its first point",
                                                  "enu": "m, the plan's local frame"},
                "spacing_m": self.spacing_m, "dose": dose, "prescription": self.prescription,
                "uniform_rate_lpha": self.uniform_rate_lpha, "canopy_source": self.canopy_source,
                "summary": self.summary(), "segments": [g.to_dict() for g in self.segments]}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SegmentRates:
        if d.get("schema") != RATES_SCHEMA:
            raise ValueError(f"not {RATES_SCHEMA}: schema {d.get('schema')!r}")
        dd = d.get("dose")
        dose = DoseExpr(dd["kind"], float(dd["value"]), int(dd.get("sides", 2))) if dd else None
        return cls(tuple(RateSegment.from_dict(g) for g in d["segments"]), float(d["spacing_m"]), dose,
                   d.get("prescription"), float(d["uniform_rate_lpha"]), str(d.get("canopy_source", "")))

    @classmethod
    def read(cls, path: Path | str) -> SegmentRates:
        return cls.from_dict(json.loads(Path(path).read_text(encoding="utf-8")))


def _rate(dose: DoseExpr, g: CanopySegment) -> float:
    if g.gap:
        return 0.0
    if dose.kind == "rate":
        return dose.value
    if dose.kind == "lwa":
        return rate_from_lwa_dose(dose.value, g.lwa_m2pha(dose.sides))
    return rate_from_trv_dose(dose.value, g.trv_m3pha())


def _piece(g: CanopySegment, s0: float, s1: float, rate: float, line: Any) -> RateSegment:
    if line is not None and (s0 != g.s0_m or s1 != g.s1_m):
        p, _ = row_stations(line, np.array([s0, s1]))
        a, b = (round(float(p[0, 0]), 4), round(float(p[0, 1]), 4)), (round(float(p[1, 0]), 4), round(float(p[1, 1]), 4))
    else:
        a, b = g.start_enu, g.end_enu
    return RateSegment(g.row, round(s0, 4), round(s1, 4), a, b, rate, g.gap, g.wall_height_m, g.width_m, g.cover,
                       g.lwa_m2pha(), g.trv_m3pha())


def _map_pieces(g: CanopySegment, rate_map: RateFn, line: Any) -> list[RateSegment]:
    """``g`` cut where the map's rate changes along it; each piece at its rate."""
    n = max(1, int(math.ceil(g.length_m / MAP_STEP_M)))
    ds = g.length_m / n
    s = g.s0_m + (np.arange(n) + 0.5) * ds
    (x0, y0), (x1, y1) = g.start_enu, g.end_enu
    f = (s - g.s0_m) / (g.length_m or 1.0)
    if line is not None:
        p, _ = row_stations(line, s)
        xs, ys = p[:, 0], p[:, 1]
    else:
        xs, ys = x0 + f * (x1 - x0), y0 + f * (y1 - y0)
    r = np.nan_to_num(np.asarray(rate_map(xs, ys), dtype=np.float64), nan=0.0)
    cuts = [0, *(np.flatnonzero(np.abs(np.diff(r)) > 1e-9) + 1).tolist(), n]
    spans: list[list[Any]] = []  # [start, end, rate]: a short piece takes the rate of the one it joins
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        if spans and (b - a) * ds < MIN_PIECE_M:
            spans[-1][1] = b
        else:
            spans.append([a, b, float(r[a])])
    if len(spans) > 1 and (spans[0][1] - spans[0][0]) * ds < MIN_PIECE_M:
        first = spans.pop(0)
        spans[0][0] = first[0]
    return [_piece(g, g.s0_m + a * ds, g.s0_m + b * ds, rate, line) for a, b, rate in spans]


def segment_rates(canopy: CanopySegments, *, dose: DoseExpr | None = None, rate_map: RateFn | None = None,
                  prescription: dict[str, Any] | None = None, rows: list[Any] | None = None,
                  uniform_rate_lpha: float | None = None) -> SegmentRates:
    """The rate of every segment of ``canopy`` for ``dose`` or ``rate_map`` (exactly one; see the module
    docstring). ``rows``: the polylines (cuts of map pieces follow them; default straight between segment ends).
    ``uniform_rate_lpha``: what the summary compares with; default the 90th percentile (by length) of the
    sprayed rates, as a fixed-rate sprayer set for the dense canopy applies everywhere."""
    if (dose is None) == (rate_map is None):
        raise ValueError("give exactly one of dose or rate_map")
    if dose is not None and dose.kind in ("lwa", "trv") and canopy.source == "rows":
        raise ValueError(f"a dose per {dose.kind.upper()} needs the canopy: no surface model or canopy for these rows")
    out: list[RateSegment] = []
    for g in canopy.segments:
        line = rows[g.row] if rows is not None else None
        if dose is not None:
            out.append(_piece(g, g.s0_m, g.s1_m, _rate(dose, g), line))
        elif g.gap:
            out.append(_piece(g, g.s0_m, g.s1_m, 0.0, line))
        else:
            assert rate_map is not None
            out += _map_pieces(g, rate_map, line)
    if uniform_rate_lpha is None:
        sprayed = sorted((g.rate_lpha, g.length_m) for g in out if g.rate_lpha > 0)
        cum = np.cumsum([w for _, w in sprayed]) if sprayed else np.zeros(0)
        uniform_rate_lpha = float(sprayed[int(np.searchsorted(cum, 0.9 * cum[-1]))][0]) if sprayed else 0.0
    return SegmentRates(tuple(out), canopy.spacing_m, dose, prescription, float(uniform_rate_lpha), canopy.source)
