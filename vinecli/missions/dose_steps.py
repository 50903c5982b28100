"""Rate steps and gaps along the rows of a dosed run, judged on the pump-delivered rate of each pass
(:mod:`vinecli.missions.as_applied`). Arc lengths along a row in m, rates in L/ha, times in s.

**Transition distance** of a step from ``old`` to ``new`` L/ha at a segment boundary: metres after the boundary
(in the direction flown) until the pass's rate is within ``tolerance`` of ``new`` (of ``old`` for a step to 0;
the next segment's length when it never is). Its **bound**: the sprayer commands the step ``v tau`` ahead of the boundary
(``tau_up`` for a rise, ``tau_down`` for a fall), so a first-order pump is at ``1/e`` of the step there and within
the tolerance ``v tau (ln(|new - old| / (tolerance' x ref)) - 1)`` metres later (0 when negative), where
``tolerance' = tolerance - speed noise / v`` (the autopilot scales the flow with its estimate of the ground speed:
an error of the GNSS velocity noise leaves that much less of the band to settle into; the vehicle's GNSS
``velocity_noise_mps``, 0 on ground truth), plus a margin:
one bin, one recorded sample's travel (``v / record rate``) and the run's position margin (the autopilot switches on
its own position estimate, not the truth: one σ of the vehicle's GNSS horizontal noise, :data:`POSITION_MARGIN_M`
by default; 0 on ground truth). A step whose next segment is shorter than its bound
cannot settle there: recorded, not judged.

**Gaps** (rate 0 between sprayed segments): the interior beyond the pump's run-down after the entry (the fall's
bound) and before the exit's opening (``v tau_up`` + the margin) must get no spray (at most ``tolerance`` of the
neighbouring rate). A gap shorter than that cannot be closed by this pump at this speed: recorded, not judged.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from vinecli.rows.dose_units import HA_M2
from vinecli.rows.segment_rates import SegmentRates

__all__ = ["POSITION_MARGIN_M", "PassRates", "StepRecord", "gap_records", "step_bound_m", "step_records",
           "traversals"]

#: along-track error allowed for switching on the position estimate by default, m (a GNSS's horizontal σ)
POSITION_MARGIN_M = 0.3


@dataclass(frozen=True)
class PassRates:
    """One pass over a row: the bins it crossed (indices), its pump rate there (L/ha), its direction along the
    row (+1 / -1) and mean ground speed (m/s)."""

    hit: np.ndarray
    vals: np.ndarray
    direction: int
    speed_mps: float


@dataclass(frozen=True)
class StepRecord:
    """A rate step flown: row, boundary (m along the row), rates before and after (L/ha), the transition
    distance (m; the next segment's length when never within), its bound (m), judged, within the bound."""

    row: int
    s_m: float
    old_lpha: float
    new_lpha: float
    distance_m: float
    bound_m: float
    reached: bool
    judged: bool
    direction: int
    speed_mps: float

    @property
    def within_bound(self) -> bool:
        return self.reached and self.distance_m <= self.bound_m

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "within_bound": self.within_bound}


def traversals(over: np.ndarray) -> Iterator[np.ndarray]:
    """Sample indices of every pass over a row: each run of two or more consecutive samples ``over`` it."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], over.astype(np.int8), [0]])))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if b - a >= 2:
            yield np.arange(a, b)


def step_bound_m(old: float, new: float, speed: float, tau_up: float, tau_down: float, tolerance: float,
                 margin_m: float, speed_noise_mps: float = 0.0) -> float:
    """Bound on the transition distance of a step ``old`` -> ``new`` L/ha at ``speed`` m/s (module docstring)."""
    ref = new if new > 0.0 else old
    tau = tau_up if new > old else tau_down
    tol = max(tolerance - (speed_noise_mps / speed if speed > 0 else 0.0), 0.5 * tolerance)
    k = math.log(abs(new - old) / (tol * ref)) - 1.0 if ref > 0 and new != old else 0.0
    return speed * tau * max(0.0, k) + margin_m


def _segments_in(rates: SegmentRates, b: dict[str, np.ndarray]) -> list[int]:
    """Indices of the rate segments present in a row's bins, in order along the row."""
    seen = b["segment"][b["segment"] >= 0]
    return [int(j) for j in dict.fromkeys(seen.tolist())]


def _margin(run: Any, speed: float, bin_m: float) -> float:
    return bin_m + speed / run.record_rate_hz + run.position_margin_m


def step_records(rates: SegmentRates, bins: list[dict[str, np.ndarray]], passes: Sequence[Sequence[PassRates]],
                 run: Any, tolerance: float, bin_m: float) -> list[StepRecord]:
    """Every rate step of every pass (module docstring)."""
    out: list[StepRecord] = []
    for k, b in enumerate(bins):
        order = _segments_in(rates, b)
        for ja, jb in zip(order[:-1], order[1:], strict=True):
            ra, rb = rates.segments[ja].rate_lpha, rates.segments[jb].rate_lpha
            for p in passes[k]:
                old, new, nxt = (ra, rb, jb) if p.direction > 0 else (rb, ra, ja)
                ref = new if new > 0.0 else old
                if ref <= 0.0 or abs(new - old) <= tolerance * ref:
                    continue
                region = np.flatnonzero(b["segment"] == nxt)
                sel = np.isin(p.hit, region)
                if not sel.any() or not np.isin(region, p.hit).all():  # the pass did not cross the whole segment
                    continue
                s_b = rates.segments[jb].s0_m
                s = b["s_m"][p.hit[sel]]
                v = p.vals[sel]
                d = np.abs(s - s_b)
                order_i = np.argsort(d)
                d, v = d[order_i], v[order_i]
                good = np.flatnonzero(np.abs(v - new) <= tolerance * ref)
                reached = good.size > 0
                dist = float(max(d[good[0]] - 0.5 * bin_m, 0.0)) if reached else 0.0
                length = float(d[-1] + 0.5 * bin_m)
                bound = step_bound_m(old, new, p.speed_mps, run.tau_up_s, run.tau_down_s, tolerance,
                                     _margin(run, p.speed_mps, bin_m), run.speed_noise_mps)
                out.append(StepRecord(k, round(s_b, 3), old, new, round(dist if reached else length, 3),
                                      round(bound, 3), reached, length >= bound, p.direction, round(p.speed_mps, 3)))
    return out


def gap_records(rates: SegmentRates, bins: list[dict[str, np.ndarray]], passes: Sequence[Sequence[PassRates]],
                run: Any, tolerance: float, bin_m: float) -> list[dict[str, Any]]:
    """Every stretch of rate 0 inside a row's planned stretch, with what the passes put there (module docstring)."""
    out: list[dict[str, Any]] = []
    per_l = bin_m * rates.spacing_m / HA_M2
    for k, b in enumerate(bins):
        order = _segments_in(rates, b)
        for n, j in enumerate(order):
            g = rates.segments[j]
            if g.rate_lpha > 0.0:
                continue
            before = rates.segments[order[n - 1]].rate_lpha if n > 0 else 0.0
            after = rates.segments[order[n + 1]].rate_lpha if n + 1 < len(order) else 0.0
            region = np.flatnonzero(b["segment"] == j)
            worst, judged = 0.0, False
            for p in passes[k]:
                r_in, r_out = (before, after) if p.direction > 0 else (after, before)
                margin = _margin(run, p.speed_mps, bin_m)
                enter = step_bound_m(r_in, 0.0, p.speed_mps, run.tau_up_s, run.tau_down_s, tolerance, margin,
                                     run.speed_noise_mps)
                leave = p.speed_mps * run.tau_up_s + margin if r_out > 0 else 0.0
                lo, hi = (g.s0_m + enter, g.s1_m - leave) if p.direction > 0 else (g.s0_m + leave, g.s1_m - enter)
                if hi <= lo:
                    continue
                inner = region[(b["s_m"][region] >= lo) & (b["s_m"][region] <= hi)]
                sel = np.isin(p.hit, inner)
                if not sel.any():
                    continue
                judged = True
                ref = max(r_in, r_out)
                worst = max(worst, float(p.vals[sel].max()) / ref if ref > 0 else float(p.vals[sel].max()))
            out.append({"row": k, "s0_m": g.s0_m, "s1_m": g.s1_m, "length_m": round(g.length_m, 3), "gap": g.gap,
                        "judged": judged, "sprayed": judged and worst > tolerance, "interior_max_ratio": round(worst, 4),
                        "litres": float(b["pump"][region].sum()) * per_l})
    return out
