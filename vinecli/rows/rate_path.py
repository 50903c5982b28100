"""Segment rates on THE spray plan's path: the litres per metre of every piece of every pass (docs/dose.md §5).

:func:`rate_path` cuts each pass of a :class:`~vinecli.rows.plan.RowPlan` where the prescribed rate under it
changes and gives each piece its litres per metre, ``rate x flow width / 10 000`` (the flow width is the plan's
track width: the built-in autopilot's flow is litres per metre x ground speed). The rate under a pass point:

* a pass over one row (layouts ``single``, ``rows``, ``listed``): that row's segment rate at the point's
  projection on the row (clamped to the row's ends: the run-on past an end keeps the end segment's rate);
* a broadcast pass between rows: the mean of the rates of the rows within half a track width of the point (the
  nearest row when none is): a broadcast layout doses several rows with one flow, so it cannot give each row its
  own rate (the run's as-applied log shows by how much each row misses).

Gaps (rate 0) are pieces with no flow: the sections close over them. The sprayer's range: at the phase's
speed a piece's flow must lie within the sprayer's flow range (nozzle pressure range, pump maximum). A piece
above it is flown slower (its speed cap, :func:`speed_caps`: the flow then stays at the top of the range); a
piece that would need a speed below the sprayer's minimum gets the top flow at that minimum speed (under-dosed);
a piece below the range gets the bottom flow (over-dosed). :attr:`RatePath.notes` says which and how much.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vinecli.geometry import distance_along
from vinecli.rows.detect import Polyline
from vinecli.rows.dose_units import HA_M2
from vinecli.rows.plan import Leg, RowPlan
from vinecli.rows.segment_rates import SegmentRates

__all__ = ["SAMPLE_M", "RatePath", "RowRates", "led_changes", "rate_legs", "rate_path", "speed_caps"]

#: spacing of the samples along a pass where the rate under it is looked up, m
SAMPLE_M = 0.05


class RowRates:
    """The rate segments of each row as arrays: rate (L/ha) at arc lengths along a row, vectorised."""

    def __init__(self, rates: SegmentRates, rows: Sequence[Polyline]) -> None:
        self.rows = [list(r) for r in rows]
        self._s0: dict[int, np.ndarray] = {}
        self._rate: dict[int, np.ndarray] = {}
        by_row: dict[int, list[Any]] = {}
        for g in rates.segments:
            by_row.setdefault(g.row, []).append(g)
        for row, segs in by_row.items():
            segs.sort(key=lambda g: g.s0_m)
            self._s0[row] = np.array([g.s0_m for g in segs])
            self._rate[row] = np.array([g.rate_lpha for g in segs])

    def at(self, row: int, s: np.ndarray) -> np.ndarray:
        """Rates (L/ha) at arc lengths ``s`` (m) along ``row``: the segment containing each (the first / last
        segment before / after the row's ends); 0 for a row without segments."""
        s0 = self._s0.get(row)
        if s0 is None or not s0.size:
            return np.zeros(np.shape(s))
        k = np.clip(np.searchsorted(s0, s, side="right") - 1, 0, s0.size - 1)
        return self._rate[row][k]

    def under(self, x: np.ndarray, y: np.ndarray, row: int | None, half_width_m: float) -> np.ndarray:
        """Rates under points (ENU m) of a pass: over ``row``, or (None) the mean of the rows within
        ``half_width_m`` of each point, else of the nearest row (module docstring)."""
        if row is not None:
            _, s = distance_along(x, y, self.rows[row])
            return self.at(row, s)
        total = np.zeros(x.shape)
        count = np.zeros(x.shape)
        best_d = np.full(x.shape, np.inf)
        best_r = np.zeros(x.shape)
        for k, line in enumerate(self.rows):
            if len(line) < 2:
                continue
            d, s = distance_along(x, y, line)
            r = self.at(k, s)
            near = d <= half_width_m
            total += np.where(near, r, 0.0)
            count += near
            closer = d < best_d
            best_d = np.where(closer, d, best_d)
            best_r = np.where(closer, r, best_r)
        return np.where(count > 0, total / np.maximum(count, 1.0), best_r)


@dataclass
class RatePath:
    """The plan as one polyline with litres per metre per segment (``flows``), the prescribed rate per segment
    (``rates``, L/ha; 0 off the passes and over gaps), the points to stop at (``stops``, as
    :meth:`RowPlan.path`), and ``notes`` on pieces outside the sprayer's range."""

    points: list[tuple[float, float]]
    flows: list[float]
    rates: list[float]
    stops: list[int]
    per_lpha: float  # litres per metre of pass per L/ha of rate (flow width / 10 000)
    notes: list[dict[str, Any]] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        """What the dose plan event says: pieces, rate range, notes."""
        sprayed = [r for r in self.rates if r > 0.0]
        return {"pieces": len(sprayed), "rate_min_lpha": round(min(sprayed), 3) if sprayed else 0.0,
                "rate_max_lpha": round(max(sprayed), 3) if sprayed else 0.0,
                "litres_per_m_per_lpha": self.per_lpha, "out_of_range": self.notes}


def _cut_leg(leg: Leg, table: RowRates, half_width_m: float) -> list[tuple[list[tuple[float, float]], float]]:
    """``leg`` cut where the rate under it changes: (polyline, rate L/ha) pieces in flight order."""
    pts = np.asarray(leg.points, dtype=np.float64)
    seg = np.hypot(*np.diff(pts, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    total = float(cum[-1])
    if total <= 0.0:
        return [(list(leg.points), 0.0)]
    n = max(2, int(math.ceil(total / SAMPLE_M)) + 1)
    d = np.linspace(0.0, total, n)
    x, y = np.interp(d, cum, pts[:, 0]), np.interp(d, cum, pts[:, 1])
    r = table.under(x, y, leg.row, half_width_m)
    change = np.flatnonzero(np.abs(np.diff(r)) > 1e-9)
    cuts = [0.0, *(0.5 * (d[change] + d[change + 1])).tolist(), total]
    rates = [float(r[0]), *r[change + 1].tolist()]
    out = []
    for (a, b), rate in zip(zip(cuts[:-1], cuts[1:], strict=True), rates, strict=True):
        inner = [(float(pts[i, 0]), float(pts[i, 1])) for i in range(len(pts)) if a < cum[i] < b]
        ends = [(float(np.interp(t, cum, pts[:, 0])), float(np.interp(t, cum, pts[:, 1]))) for t in (a, b)]
        out.append(([ends[0], *inner, ends[1]], rate))
    return out


def rate_path(plan: RowPlan, rates: SegmentRates, rows: Sequence[Polyline], *, speed_mps: float,
              flow_range_lps: tuple[float, float], speed_min_mps: float) -> RatePath:
    """``plan``'s path with each pass cut at the rate changes under it and the litres per metre of each piece
    (module docstring); ``rows``: the polylines the rates' ``row`` indices refer to (the plan's rows)."""
    width = plan.flow_width_m
    if not width > 0.0:
        raise ValueError("the plan has no track width (no sprayer pattern): segment rates need one")
    per_lpha = width / HA_M2
    lo, hi = flow_range_lps
    broadcast = plan.layout is not None and plan.layout.mode == "broadcast"
    table = RowRates(rates, rows)
    pts: list[tuple[float, float]] = [plan.legs[0].points[0]] if plan.legs else []
    flows: list[float] = []
    prescribed: list[float] = []
    stops: list[int] = []
    out_of_range: dict[str, dict[str, Any]] = {}
    for leg in plan.legs:
        pieces = _cut_leg(leg, table, 0.5 * width) if leg.spray else [(list(leg.points), 0.0)]
        for poly, rate in pieces:
            per_m = rate * per_lpha
            if rate > 0.0:
                per_m = _within_range(per_m, rate, poly, speed_mps, lo, hi, speed_min_mps, out_of_range)
            for p in poly[1:]:
                pts.append(p)
                flows.append(per_m)
                prescribed.append(rate)
        if leg.kind == "transit" and len(leg.points) >= 3:
            stops.append(len(pts) - 2)
    notes = [{"kind": k, **v, "length_m": round(v["length_m"], 2)} for k, v in out_of_range.items()]
    if broadcast:
        notes.append({"kind": "broadcast", "note": "passes laid over several rows: each pass flies the mean rate of "
                                                  "the rows under it, not each row's own"})
    return RatePath(pts, flows, prescribed, stops, per_lpha, notes)


def _within_range(per_m: float, rate: float, poly: list[tuple[float, float]], v: float, lo: float, hi: float,
                  v_min: float, notes: dict[str, dict[str, Any]]) -> float:
    """The litres per metre a piece flies within the sprayer's range (module docstring); ``notes`` counts the
    pieces changed by kind."""
    q = per_m * v
    length = sum(math.dist(a, b) for a, b in zip(poly[:-1], poly[1:], strict=True))
    kind = ""
    if q > hi * (1 + 1e-9):
        kind = "slowed" if hi / per_m >= v_min else "under-dosed"
        if kind == "under-dosed":
            per_m = hi / v_min
    elif q < lo * (1 - 1e-9):
        kind, per_m = "over-dosed", lo / v
    if kind:
        n = notes.setdefault(kind, {"pieces": 0, "length_m": 0.0, "rates_lpha": [math.inf, 0.0]})
        n["pieces"] += 1
        n["length_m"] += length
        n["rates_lpha"] = [min(n["rates_lpha"][0], round(rate, 3)), max(n["rates_lpha"][1], round(rate, 3))]
    return per_m


def speed_caps(flows: Sequence[float], speed_mps: float, max_flow_lps: float) -> list[float]:
    """The speed each path segment may be flown at (m/s): the phase's, or slower where its litres per metre at
    that speed would need more than ``max_flow_lps``."""
    return [min(speed_mps, max_flow_lps / f) if f > 0.0 else speed_mps for f in flows]


def led_changes(points: Sequence[tuple[float, float]], flows: Sequence[float], lead_up_m: float, lead_down_m: float
                ) -> tuple[list[tuple[float, float]], list[float]]:
    """The path with every change of flow moved ``lead_up_m`` (a rise) or ``lead_down_m`` (a fall) earlier along
    it (not before the previous change): what a firmware that switches at waypoints must be given so that its
    lagging pump changes at the segment boundary. A pass's opening and closing move too."""
    pts = np.asarray(points, dtype=np.float64)
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    starts = [0.0]
    values = [flows[0]] if flows else []
    for i in range(1, len(flows)):
        if flows[i] != flows[i - 1]:
            lead = lead_up_m if flows[i] > flows[i - 1] else lead_down_m
            starts.append(max(float(cum[i]) - lead, starts[-1]))
            values.append(flows[i])
    cuts = sorted(set(starts[1:]) | set(cum.tolist()))
    out_pts = [(float(np.interp(c, cum, pts[:, 0])), float(np.interp(c, cum, pts[:, 1]))) for c in cuts]
    out_flows = []
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        k = int(np.searchsorted(starts, 0.5 * (a + b), side="right")) - 1
        out_flows.append(float(values[k]))
    return out_pts, out_flows


def rate_legs(points: Sequence[tuple[float, float]], flows: Sequence[float], *, merge_sprayed: bool = False,
              min_leg_m: float = 0.0) -> list[tuple[Leg, float]]:
    """The path cut into legs of one flow each: (leg, litres per metre); a leg with flow is a spray leg.
    ``merge_sprayed``: consecutive spray legs stay one (its flow the first's: a firmware that only switches the
    sprayer on and off, the rate set otherwise). ``min_leg_m``: consecutive spray legs are joined until each is
    at least this long, at their length-weighted litres per metre (a firmware that slows down at waypoints
    closer than that)."""
    out: list[tuple[Leg, float]] = []
    for i, f in enumerate(flows):
        a, b = points[i], points[i + 1]
        last = out[-1] if out else None
        same = last is not None and (last[1] == f or (merge_sprayed and last[1] > 0.0 and f > 0.0))
        if same and last is not None:
            last[0].points.append(b)
        else:
            out.append((Leg([a, b], f > 0.0, None, "row" if f > 0.0 else "gap"), f))
    if min_leg_m <= 0.0:
        return out
    joined: list[tuple[Leg, float]] = []
    for leg, f in out:
        prev = joined[-1] if joined else None
        if prev is not None and prev[1] > 0.0 and f > 0.0 and (prev[0].length_m < min_leg_m or leg.length_m < min_leg_m):
            la, lb = prev[0].length_m, leg.length_m
            joined[-1] = (Leg([*prev[0].points, *leg.points[1:]], True, None, "row"), (prev[1] * la + f * lb) / (la + lb))
        else:
            joined.append((leg, f))
    return joined
