"""Where the passes go: lanes across a block of rows from the sprayer's pattern (ENU m).

:func:`layout_lanes` places the passes so that every row, the edge rows included, gets the asked
rate on its canopy band. It works on the rows' positions across the block and the expected
cross-track pattern of one pass (:class:`~vinecli.spray.swath.SwathPattern`):

* one row: one pass over it; the flow doses its band (``flow_width`` = the single-pass width);
* rows at least an effective swath apart: one pass over each row, its flow dosing the band with the
  neighbouring passes' overlap counted (the single-pass width over the midrange of the rows' expected doses:
  the wake-narrowed plume can still reach the next row); a row listed twice: a pass per listed row, flown in the
  order listed, ``listed``;
* otherwise broadcast: n evenly spaced passes from ``first row + e`` to ``last row - e``, their
  spacing S at most the effective swath and within the CV limit of the overlapped pattern, with the
  flow of S (rate x S x speed). n and the edge offset e (passes beyond the edge rows for e < 0, inside
  for e > 0) are chosen so that the expected mean rate on every row's band is closest to the asked one,
  the fewest passes first among the layouts within :data:`ROW_TARGET` as planned and within
  :data:`ROW_TARGET_OFF_TRACK` with any one pass flown :data:`TRACK_ERROR_M` off its line (the estimate's
  bias differs from pass to pass; a row on the steep flank of a pattern would take it as a dose error).

:func:`lane_polyline` builds a pass's path: the rows it lies between interpolated at matching positions along
the block (not at matching arc-length fractions: rows of different extent would bend the pass), or the edge
row shifted across.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vinecli.rows.detect import Polyline

__all__ = ["ROW_TARGET", "TRACK_ERROR_M", "LaneLayout", "lane_polyline", "layout_lanes"]

#: expected deviation of a row's mean rate from the asked one a layout aims for (the dose check allows 15 %)
ROW_TARGET = 0.08
#: ... and flown off its lines by TRACK_ERROR_M (the dose check allows 15 %: 3 % left for the rest)
ROW_TARGET_OFF_TRACK = 0.12
#: cross-track error of a flown pass the layouts must tolerate, m (the built-in autopilot's position estimate drifts
#: by ~0.1-0.15 m over a pass on the x500-sprayer's GNSS)
TRACK_ERROR_M = 0.1
#: ... and with every pass's pattern PATTERN_WIDTH_ERROR wider or narrower than planned (the spray height held within
#: ~0.1 m, the downwash of a fuller or emptier tank): rows midway between passes sit on two patterns' flanks. Flown,
#: the ag-hexa-16's 14 passes 4.03 m apart over rows 2.8 m apart (planned worst row 7.9 %, 11.4 % at ±5 % width)
#: dosed the rows midway between passes 11-15 % low over six seeds
PATTERN_WIDTH_ERROR = 0.05
ROW_TARGET_WIDTH = 0.10
_E_STEP = 0.05  # m, edge offsets tried
_BAND_STEP = 0.02  # m, samples across a row's band


@dataclass(frozen=True)
class LaneLayout:
    """Passes across a block: ``across_m`` the pass positions (across coordinate, m), ``flow_width_m`` the track
    width of the flow (flow = rate x width x speed / 10 000), ``row_dose`` the expected mean rate of each row
    relative to the asked one, ``mode`` single | rows | listed | broadcast."""

    across_m: list[float]
    flow_width_m: float
    spacing_m: float
    row_dose: list[float]
    mode: str
    edge_offset_m: float = 0.0

    @property
    def worst_row_error(self) -> float:
        """Largest |expected row rate / asked - 1|."""
        return max((abs(d - 1.0) for d in self.row_dose), default=0.0)


def _row_doses(pattern: object, rows: np.ndarray, lanes: Sequence[float], width: float, band_m: float,
               scale: float = 1.0) -> list[float]:
    """Expected mean rate on each row's band (relative to the asked one) of passes at ``lanes`` alternating in
    direction, each with the flow of ``width``; ``scale``: each pass's pattern that much wider (same litres)."""
    half = 0.5 * band_m
    off = np.arange(-half, half + 1e-9, _BAND_STEP)
    ys = (rows[:, None] + off[None, :]).ravel()
    passes = [(c, 1 if k % 2 == 0 else -1) for k, c in enumerate(lanes)]
    if scale == 1.0:
        dose = pattern.dose(ys, passes)  # type: ignore[attr-defined]
    else:
        dose = sum(pattern.dose(c + (ys - c) / scale, [(c, d)]) for c, d in passes) / scale  # type: ignore[attr-defined]
    return [float(v) for v in (dose.reshape(rows.size, off.size).mean(axis=1) * width)]


def _robust(pattern: object, rows: np.ndarray, lay: LaneLayout, band_m: float) -> bool:
    """The layout keeps every row within ROW_TARGET_OFF_TRACK with any one pass flown TRACK_ERROR_M off its line, and
    within ROW_TARGET_WIDTH with every pass's pattern PATTERN_WIDTH_ERROR wider or narrower than planned."""
    def worst(doses: list[float]) -> float:
        return max(abs(d - 1.0) for d in doses)

    if max(worst(_row_doses(pattern, rows, shifted, lay.spacing_m, band_m)) for shifted in _off_track(lay.across_m)) \
            > ROW_TARGET_OFF_TRACK:
        return False
    return all(worst(_row_doses(pattern, rows, lay.across_m, lay.spacing_m, band_m, f)) <= ROW_TARGET_WIDTH
               for f in (1.0 - PATTERN_WIDTH_ERROR, 1.0 + PATTERN_WIDTH_ERROR))


def _off_track(lanes: list[float]) -> list[list[float]]:
    """The layout with one pass flown TRACK_ERROR_M off its line (each pass, each way: the estimate's bias
    differs from pass to pass)."""
    d = TRACK_ERROR_M
    return [[c + (sign * d if j == k else 0.0) for j, c in enumerate(lanes)] for k in range(len(lanes))
            for sign in (1.0, -1.0)]


def layout_lanes(across: Sequence[float], pattern: object, band_m: float, target: float = ROW_TARGET) -> LaneLayout:
    """Passes for rows at ``across`` (m, any order) under ``pattern`` (a SwathPattern), canopy band ``band_m``."""
    # a crosswind carries the plume across the rows: the passes are laid that far upwind (swath displacement)
    drift = float(getattr(pattern, "centre_m", 0.0))
    if abs(drift) > 1e-3:  # a millimetre: calm air (the pattern's centroid is 0 to rounding)
        lay = layout_lanes(across, _Recentred(pattern, drift), band_m, target)
        lanes = [c - drift for c in lay.across_m]
        rows = np.asarray(across, dtype=np.float64) if lay.mode == "listed" else np.sort(np.asarray(across, float))
        return LaneLayout(lanes, lay.flow_width_m, lay.spacing_m, _row_doses(pattern, rows, lanes, lay.flow_width_m,
                                                                              band_m), lay.mode, lay.edge_offset_m)
    xs = np.sort(np.asarray(across, dtype=np.float64))
    w1 = pattern.single_pass_width_m(band_m)  # type: ignore[attr-defined]
    eff = float(pattern.effective_m)  # type: ignore[attr-defined]
    gaps = np.diff(xs)
    if gaps.size and float(np.min(gaps)) < 1e-6:  # a row listed twice: a pass per listed row, in the order listed
        lanes = [float(x) for x in across]
        return LaneLayout(lanes, w1, math.nan, _row_doses(pattern, xs, lanes, w1, band_m), "listed")
    if xs.size == 1 or not math.isfinite(eff) or float(np.min(gaps)) >= eff:
        lanes = [float(x) for x in xs]
        mode = "single" if xs.size == 1 else "rows"
        spacing = float(np.median(gaps)) if gaps.size else math.nan
        return _rows_layout(pattern, xs, lanes, w1, band_m, spacing, mode)
    span = float(xs[-1] - xs[0])
    n0 = int(math.ceil(span / eff - 1e-9)) + 1
    fallback: tuple[float, LaneLayout] | None = None
    for n in range(max(n0, 2), n0 + 5):
        candidates: list[tuple[float, LaneLayout]] = []
        for e in np.arange(-0.5 * eff, 0.5 * eff + 1e-9, _E_STEP):
            s = (span - 2.0 * e) / (n - 1)
            if s <= 0.0 or s > eff + 1e-9 or not pattern.good(s):  # type: ignore[attr-defined]
                continue
            lanes = [float(xs[0] + e + k * s) for k in range(n)]
            doses = _row_doses(pattern, xs, lanes, s, band_m)
            err = max(abs(d - 1.0) for d in doses)
            lay = LaneLayout(lanes, s, s, doses, "broadcast", float(e))
            candidates.append((err, lay))
            if fallback is None or err < fallback[0]:
                fallback = (err, lay)
        for err, lay in sorted(candidates, key=lambda c: c[0]):  # the best planned dose that survives flight errors
            if err > target:
                break
            if _robust(pattern, xs, lay, band_m):
                return lay
    if fallback is None:  # no spacing passes the CV limit: one pass per row
        lanes = [float(x) for x in xs]
        return _rows_layout(pattern, xs, lanes, w1, band_m, float(np.median(gaps)), "rows")
    return fallback[1]


def _rows_layout(pattern: object, xs: np.ndarray, lanes: list[float], w1: float, band_m: float, spacing: float,
                 mode: str) -> LaneLayout:
    """A pass over each row. Its flow doses the rows' bands at the asked rate with the neighbouring passes' overlap
    and the vehicle's cross-track error counted: the single-pass width divided by the midrange of the rows'
    expected doses as flown (passes on their lines or TRACK_ERROR_M off them), so the edge rows (one neighbour) and
    the inner rows (two) are equally far from the asked rate (a plume wider than the row spacing lays part of each
    pass on the neighbours; a plume much wider than the track error: 1 for a lone row)."""
    doses = _row_doses(pattern, xs, lanes, w1, band_m)
    own = _row_doses(pattern, np.zeros(1), [0.0], w1, band_m)[0]  # a row's own pass alone
    # as flown: the passes TRACK_ERROR_M to either side as often as on their lines (a narrow plume loses part of
    # the band to the estimate's cross-track error; the flow makes up for it)
    flown = np.mean([_row_doses(pattern, xs, [c + d for c in lanes], w1, band_m)
                     for d in (-TRACK_ERROR_M, 0.0, TRACK_ERROR_M)], axis=0)
    k = 0.5 * (float(flown.min()) + float(flown.max())) / own if own > 0 else 1.0
    return LaneLayout(lanes, w1 / k, spacing, [d / k for d in doses], mode)


def _along_across(line: np.ndarray, u: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(along, across) coordinates (m) of a polyline's vertices, along made non-decreasing (np.interp's grid)."""
    return np.maximum.accumulate(line @ u), line @ n


def lane_polyline(rows: Sequence[Polyline], across: Sequence[float], c: float,
                  normal: tuple[float, float]) -> list[tuple[float, float]]:
    """The path of a pass at across position ``c`` (m): between the two rows around it, their across positions
    interpolated at matching positions ALONG the block (each row held at its end's across position beyond its
    end), over the union of the two rows' along extents, so rows of different length (a row beside a shorter one,
    a row cut by a no-spray zone) do not bend the pass; beyond the outer rows, the outer row shifted across by the
    distance (``normal`` the unit across vector). ``rows`` and ``across`` are aligned."""
    order = np.argsort(np.asarray(across, dtype=np.float64))
    xs = np.asarray(across, dtype=np.float64)[order]
    lines = [np.asarray(rows[i], dtype=np.float64) for i in order]
    nx, ny = normal
    u, n = np.array([ny, -nx]), np.array([nx, ny])
    u = u if float(np.dot(lines[0][-1] - lines[0][0], u)) >= 0 else -u  # the pass runs as the first row
    lines = [ln if float(np.dot(ln[-1] - ln[0], u)) >= 0 else ln[::-1] for ln in lines]
    if c <= xs[0] or c >= xs[-1] or xs.size == 1:
        k = 0 if c <= xs[0] else xs.size - 1
        d = c - float(xs[k])
        return [(float(x + d * nx), float(y + d * ny)) for x, y in lines[k]]
    j = int(np.searchsorted(xs, c))  # xs[j-1] < c <= xs[j]
    (ta, sa), (tb, sb) = _along_across(lines[j - 1], u, n), _along_across(lines[j], u, n)
    w = (c - float(xs[j - 1])) / (float(xs[j] - xs[j - 1]) or 1.0)
    t = np.unique(np.round(np.concatenate([ta, tb]), 9))
    s = (1.0 - w) * np.interp(t, ta, sa) + w * np.interp(t, tb, sb)
    pts = t[:, None] * u[None, :] + s[:, None] * n[None, :]
    return [(float(x), float(y)) for x, y in pts]


class _Recentred:
    """A pattern moved across so that its plume lands under the pass (its crosswind drift taken out): the layout of
    passes over the rows, before they are displaced upwind by the drift."""

    def __init__(self, pattern: object, drift_m: float) -> None:
        self.pattern = pattern
        self.drift_m = drift_m
        self.effective_m = float(pattern.effective_m)  # type: ignore[attr-defined]

    def good(self, spacing_m: float) -> bool:
        return bool(self.pattern.good(spacing_m))  # type: ignore[attr-defined]

    def single_pass_width_m(self, band_m: float) -> float:
        mean = self.pattern.band_mean(0.5 * band_m, self.drift_m)  # type: ignore[attr-defined]
        return 1.0 / mean if mean > 0 else math.inf

    def dose(self, y: np.ndarray, lanes: list[tuple[float, int]]) -> np.ndarray:
        return self.pattern.dose(np.asarray(y) + self.drift_m, lanes)  # type: ignore[attr-defined,no-any-return]
