"""Crop/vine row detection on a regular height grid (local metres: x east, y north; heights m).

The one row detector of vinecli (``world build`` with ``rows: auto``, ``plan rows`` and the run-time
detection all call :func:`detect_rows_grid`). It fits a model of the whole row pattern, not rows one by one:

1. direction and spacing: the peak of the 2-D spectrum of the plane-detrended heights in the spacing band,
   refined by the sharpest lateral profile (:mod:`~vinecli.rows.spectrum`);
2. canopy relief (a canopy height model without a DTM): heights minus a NaN-aware Gaussian estimate of the
   ground one spacing wide, so slopes and undulations drop out and young vines, hills and hedges stand out;
3. the comb: rows at ``s = delta(t) + k x spacing`` across the rows, its phase and explained variance
   measured strip by strip and window by window (:mod:`~vinecli.rows.comb`); the windows where it explains
   the relief are the row field (a DSM that is only partly a vineyard), its unwrapped phase along the rows
   the shift all rows share (gentle common curvature);
4. refusal: no clear spectral peak, a comb explaining too little of the relief, or too small a row field
   -> :class:`NoRowsError` with that evidence (flat fields, woodland, buildings, plain DEMs);
5. each row: its own centre in every strip (the profile peak within a third of a spacing of the comb's
   prediction), a robust fit through them (RANSAC, then a smoothing spline at the knots' own noise),
   stretches without canopy over ``max_gap_m`` split, ends trimmed to where the canopy ends, simplified to
   2 cm; a confidence per row (support x contrast x fit).

Directions are angles in degrees from east (x), counter-clockwise, folded to [0, 180) (the rows' mean
direction); every row polyline runs along it; rows are numbered from west (rows running north-south)
or from south (rows running east-west).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import TerrainError
from vinecli.geometry import polyline_length
from vinecli.rows.comb import Comb, RowKnots, comb_of, eval_row, fit_row, make_strips, row_knots
from vinecli.rows.spectrum import decimate, direction_and_spacing, fill_and_detrend, relief_of
from vinecli.spray.canopy import row_spacing

Polyline = list[tuple[float, float]]

__all__ = ["NoRowsError", "Polyline", "RowDetection", "RowEvidence", "detect_rows_grid"]


@dataclass
class RowDetection:
    """Detected rows in the grid's frame (m): direction (deg from x/east, [0, 180)), spacing (m),
    centre lines, spectral strength (peak / median power in the spacing band; > ~20: clear rows) and a
    confidence in [0, 1] (support x regularity x strength factor, see :func:`detect_rows_grid`)."""

    direction_deg: float
    spacing_m: float
    rows: list[Polyline] = field(default_factory=list)
    strength: float = 0.0
    confidence: float = 0.0
    support: list[float] = field(default_factory=list)  # per row: fraction of its strips where it was seen
    row_confidence: list[float] = field(default_factory=list)  # per row, 0-1: support x contrast x fit
    evidence: RowEvidence | None = None

    @property
    def lengths_m(self) -> list[float]:
        """Length of each row polyline, m."""
        return [polyline_length(r) for r in self.rows]

    def summary(self) -> str:
        """One line: count, spacing, orientation (ENU angle and compass bearing), confidence."""
        d = 0.0 if self.direction_deg >= 179.95 else self.direction_deg  # as printed with one decimal
        bearing = (90.0 - d) % 180.0
        total = sum(self.lengths_m)
        return (f"{len(self.rows)} rows, spacing {self.spacing_m:.3f} m, direction {d:.1f} deg from "
                f"east (bearing {bearing:.1f}/{bearing + 180:.1f} deg), {total:.1f} m of rows, "
                f"confidence {self.confidence:.2f}")

    def to_dict(self) -> dict[str, Any]:
        """JSON form (``rows_enu``: polylines as lists of [x, y])."""
        return {"count": len(self.rows), "direction_deg": self.direction_deg, "spacing_m": self.spacing_m,
                "strength": self.strength, "confidence": self.confidence,
                "lengths_m": [round(v, 3) for v in self.lengths_m], "support": self.support,
                "row_confidence": self.row_confidence,
                "evidence": dataclasses.asdict(self.evidence) if self.evidence is not None else None,
                "rows_enu": [[list(p) for p in r] for r in self.rows]}


def _trim_ends(t: np.ndarray, s: np.ndarray, to_xy: Any, relief: np.ndarray, x: np.ndarray, y: np.ndarray,
               spacing: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Trim the line's ends to where the row is: the grid has data on the line and 0.3 spacing either side
    of it (a row cut lengthwise by the data's edge is not centred), and the relief along the line, averaged
    over half a spacing, is at least half its median over the line. None if nothing is left."""
    from scipy.ndimage import uniform_filter1d

    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])

    def sample(ds: float) -> np.ndarray:
        px, py = to_xy(s + ds, t)
        ii = np.round((px - x[0]) / dx).astype(int)
        jj = np.round((py - y[0]) / dy).astype(int)
        inside = (ii >= 0) & (ii < x.size) & (jj >= 0) & (jj < y.size)
        out = np.full(t.size, np.nan)
        out[inside] = relief[jj[inside], ii[inside]]
        return out

    h = sample(0.0)
    ok = np.isfinite(h) & np.isfinite(sample(-0.3 * spacing)) & np.isfinite(sample(0.3 * spacing))
    if ok.sum() < 2:
        return None
    n = max(1, int(round(0.5 * spacing / max(float(t[1] - t[0]), 1e-9))))
    hs = uniform_filter1d(np.where(ok, h, 0.0), n) / np.maximum(uniform_filter1d(ok.astype(float), n), 1e-9)
    thr = 0.5 * float(np.median(hs[ok]))
    present = ok & (hs >= thr) if thr > 0 else ok
    if not present.any():
        return None
    a, b = int(np.argmax(present)), int(len(present) - 1 - np.argmax(present[::-1]))
    return t[a:b + 1], s[a:b + 1]


def _simplify(pts: np.ndarray, tol: float) -> np.ndarray:
    """Douglas-Peucker simplification of an (n, 2) polyline (shapely)."""
    from shapely.geometry import LineString

    if len(pts) <= 2:
        return pts
    return np.asarray(LineString(pts).simplify(tol, preserve_topology=False).coords)


@dataclass
class RowEvidence:
    """What the detector measured about the row pattern, whether or not it found rows: the spectral peak
    (``strength``: its power over the median power of all directions at its wavelength), the share of the relief variance the
    comb explains (median over the field's windows, ``r2_field``; over the row field alone, ``r2_rows``), the
    share of the field's windows that form the row field (``row_area_fraction``)."""

    spacing_m: float
    direction_deg: float
    strength: float
    r2_field: float
    r2_rows: float
    row_area_fraction: float

    def describe(self) -> str:
        """The evidence in one phrase."""
        return (f"best periodic pattern {self.spacing_m:.2f} m at {self.direction_deg:.0f} deg from east: spectral "
                f"peak {self.strength:.0f}x the median power at its wavelength (rows: >= {MIN_STRENGTH:.0f}x), the comb explains "
                f"{100 * self.r2_field:.0f} % of the relief variance (rows: >= {100 * MIN_R2:.0f} %), "
                f"{100 * self.row_area_fraction:.0f} % of the area row-like")


#: refusal thresholds (calibrated on the real surveys and the no-row rasters, README "Rows and spray plans")
MIN_STRENGTH = 100.0
MIN_R2 = 0.3
MIN_ROW_AREA = 0.05


class NoRowsError(TerrainError):
    """The height grid shows no row pattern (exit 2); ``evidence`` says what was measured."""

    def __init__(self, message: str, evidence: RowEvidence | None = None, *, path: str | Path | None = None) -> None:
        super().__init__(message, path=path)
        self.evidence = evidence


# parameters: keyword-only options, each with its default (the detector's tuning); a caller names the ones it sets
def detect_rows_grid(
    z: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    *,
    min_spacing_m: float = 0.5,
    max_spacing_m: float = 6.0,
    spacing_m: float | None = None,
    min_length_m: float | None = None,
    max_gap_m: float = 4.0,
    min_prominence: float = 0.3,
    max_cells: int = 300_000,
) -> RowDetection:
    """Detect rows in a regular height grid ``z[j, i]`` at ``x[i]``, ``y[j]`` (m, uniform; NaN = no data).

    ``spacing_m`` fixes the expected spacing (searched within ±25 %). Rows shorter than ``min_length_m``
    (default: 3 spacings or two strips) are dropped; a row with no canopy over more than ``max_gap_m`` is two
    rows. A row is seen in a strip where its contrast (peak over the inter-row ground) is at least
    ``min_prominence`` x the field's 90th percentile. Grids larger than ``max_cells`` are block-averaged first.
    Raises :class:`NoRowsError` (with the evidence) on land without a row pattern.
    """
    z = np.asarray(z, dtype=float)
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if z.shape != (y.size, x.size) or x.size < 8 or y.size < 8:
        raise TerrainError(f"height grid must be at least 8x8 and match x, y (got {z.shape})")
    z, x, y = decimate(z, x, y, max_cells)
    zz, valid = fill_and_detrend(z)
    lo, hi = (spacing_m * 0.75, spacing_m * 1.25) if spacing_m else (min_spacing_m, max_spacing_m)
    nvec, p, strength = direction_and_spacing(zz, valid, x, y, lo, hi)
    cell = min(abs(float(x[1] - x[0])), abs(float(y[1] - y[0])))
    relief = relief_of(np.where(valid, z, np.nan), valid, p / cell)
    u = np.array([-nvec[1], nvec[0]])
    if math.atan2(u[1], u[0]) < -1e-9 or math.atan2(u[1], u[0]) >= math.pi - 1e-9:
        u = -u
    n = np.array([-u[1], u[0]])  # left normal of u
    direction = math.degrees(math.atan2(u[1], u[0])) % 180.0
    X, Y = np.meshgrid(x, y)
    ok = valid & np.isfinite(relief)
    s, t, h = X[ok] * n[0] + Y[ok] * n[1], X[ok] * u[0] + Y[ok] * u[1], relief[ok]
    st = make_strips(s, t, h, max(1.5 * p, 4 * cell), min(cell, p / 8))
    comb = comb_of(st, p)
    ev = RowEvidence(round(p, 3), round(direction, 1), round(strength, 1), round(comb.r2_field, 3),
                     round(float(np.median(comb.r2[comb.region])) if comb.region.any() else 0.0, 3),
                     round(float(comb.region.mean()), 3))
    _refuse_without_rows(ev)
    _refuse_rows_between_rows(st, comb, ev)
    kn = row_knots(st, comb)

    def to_xy(ss: np.ndarray, tt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return ss * n[0] + tt * u[0], ss * n[1] + tt * u[1]

    min_len = min_length_m if min_length_m is not None else max(3 * p, 2 * st.length)
    inputs = _FitInputs(kn, comb, st, to_xy, relief, x, y, min_len, max(cell, 0.05))
    found = _fit_rows(inputs, max(1, int(math.floor(max_gap_m / st.length))), min_prominence)
    found = _rows_of_the_field(found)
    if not found:
        raise NoRowsError(f"no row found: {ev.describe()}", ev)
    order_sign = 1.0 if n[0] + n[1] >= 0 else -1.0  # number rows from west / south
    found.sort(key=lambda f: order_sign * f.mean_s)
    rows = [f.line for f in found]
    direction = _mean_direction(rows)
    det = RowDetection(direction, round(p, 4), rows, round(strength, 2))
    det.support = [round(f.support, 3) for f in found]
    det.row_confidence = [round(f.confidence, 3) for f in found]
    det.evidence = ev
    det.confidence = _confidence(found, p, strength, det.lengths_m)
    return det


def _refuse_without_rows(ev: RowEvidence) -> None:
    """NoRowsError unless the grid shows a row pattern: a clear spectral peak, a comb explaining a good share
    of the relief variance over the row field, and a row field of some size."""
    if ev.strength < MIN_STRENGTH or ev.r2_rows < MIN_R2 or ev.row_area_fraction < MIN_ROW_AREA:
        raise NoRowsError(f"no row pattern: {ev.describe()}", ev)


@dataclass
class _Found:
    line: Polyline
    mean_s: float
    support: float
    confidence: float
    t: np.ndarray
    s: np.ndarray
    contrast: float = 0.0  # median relief of the row over the ground beside it, m


#: a ridge with less than this share of the field's median row contrast is not one of its rows (a guard ridge,
#: a wheel track, the ridges of a bare neighbouring plot), README "Rows and spray plans"
MIN_ROW_CONTRAST = 0.5


def _rows_of_the_field(found: list[_Found]) -> list[_Found]:
    """The rows whose contrast is at least :data:`MIN_ROW_CONTRAST` x the length-weighted median contrast of all."""
    if len(found) < 3:
        return found
    c = np.array([f.contrast for f in found])
    w = np.array([float(f.t[-1] - f.t[0]) for f in found])
    o = np.argsort(c)
    med = float(c[o][np.searchsorted(np.cumsum(w[o]), 0.5 * w.sum())])
    return [f for f in found if f.contrast >= MIN_ROW_CONTRAST * med]


def _refuse_rows_between_rows(st: Any, comb: Comb, ev: RowEvidence) -> None:
    """NoRowsError when the comb runs along low, wide strips with taller features half a spacing beside them:
    the 99th percentile of the relief (the tallest plants) within an eighth of a spacing of the comb's lines is below that of the
    lines between them (grass strips between young vines: the grass has the larger mean relief, the vines the
    taller plants). From a DSM alone the detector cannot tell the rows from the inter-rows, so it says so."""
    p = comb.spacing
    off = np.mod(st.s - comb.shift(st.t), p)
    inside = comb.in_region(st.k, st.s)
    on = inside & ((off <= p / 8) | (off >= 7 * p / 8))
    mid = inside & (np.abs(off - p / 2) <= p / 8)
    if on.sum() < 16 or mid.sum() < 16:
        return
    q_on, q_mid = float(np.percentile(st.h[on], 99)), float(np.percentile(st.h[mid], 99))
    if q_mid > q_on:
        raise NoRowsError(f"the row pattern runs along low wide strips with taller plants between them (99th "
                          f"percentile of the relief {q_on:.2f} m on the strips, {q_mid:.2f} m between them, e.g. "
                          f"grass strips between young vines): cannot tell the rows from the inter-rows; "
                          f"{ev.describe()}", ev)


@dataclass(frozen=True)
class _FitInputs:
    """What the row fit reads of a field: its comb rows' knots, the comb, the strips, the map from (across, along)
    to ENU x, y, the relief grid and its axes, the shortest row kept (m) and the centre lines' step (m)."""

    kn: RowKnots
    comb: Comb
    st: Any
    to_xy: Any
    relief: np.ndarray
    x: np.ndarray
    y: np.ndarray
    min_len: float
    step: float


def _fit_rows(inputs: _FitInputs, gap_strips: int, min_prominence: float) -> list[_Found]:
    """Each comb row's stretches of knots fitted into centre lines (see :mod:`vinecli.rows.comb`)."""
    kn, comb = inputs.kn, inputs.comb
    p = comb.spacing
    seen = kn.inside & np.isfinite(kn.contrast)
    if not seen.any():
        return []
    thr = max(min_prominence * float(np.percentile(kn.contrast[seen], 90)), 1e-6)
    pred = comb.delta[None, :] + kn.k[:, None] * p
    good = seen & (kn.contrast >= thr) & (np.abs(kn.s - pred) <= p / 4)
    out: list[_Found] = []
    for r in range(kn.k.size):
        js = np.flatnonzero(good[r])
        if js.size < 2:
            continue
        for run in np.split(js, np.flatnonzero(np.diff(js) > gap_strips + 1) + 1):
            f = _fit_run(inputs, r, run, thr)
            if f is not None:
                out.append(f)
    return out


def _fit_run(inputs: _FitInputs, r: int, run: np.ndarray, thr: float) -> _Found | None:
    """One stretch (the knots ``run``) of comb row ``r``: robust centre line, ends trimmed to the canopy, support and
    confidence; ``thr`` the contrast a knot needs."""
    kn, st, comb, to_xy, step = inputs.kn, inputs.st, inputs.comb, inputs.to_xy, inputs.step
    p = comb.spacing
    if run.size < 2:
        return None
    tk, sk = kn.t[r, run], kn.s[r, run]
    fit = fit_row(tk, sk, p)
    if fit is None:
        return None
    keep, sigma = fit
    tk, sk = tk[keep], sk[keep]
    t0, t1 = float(st.t_centre[run[0]] - st.length), float(st.t_centre[run[-1]] + st.length)
    tl = np.arange(t0, t1 + step / 2, step)
    sl = eval_row(tk, sk, sigma, tl, p, comb.shift)
    trimmed = _trim_ends(tl, sl, to_xy, inputs.relief, inputs.x, inputs.y, p)
    if trimmed is None or trimmed[0][-1] - trimmed[0][0] < inputs.min_len:
        return None
    tl, sl = trimmed
    px, py = to_xy(sl, tl)
    pts = _simplify(np.column_stack([px, py]), 0.02)
    line = [(round(float(a), 3), round(float(b), 3)) for a, b in pts]
    span = run[-1] - run[0] + 1
    support = float(keep.sum()) / span
    contrast = float(np.median(kn.contrast[r, run][keep]))
    conf = support * min(1.0, contrast / (2 * thr)) * max(0.0, 1.0 - sigma / (p / 4))
    return _Found(line, float(np.mean(sl)), support, conf, tl, sl, contrast)


def _mean_direction(rows: list[Polyline]) -> float:
    """The rows' mean direction, deg from east in [0, 180): length-weighted end-to-end, doubled angles."""
    ends = np.array([[r[-1][0] - r[0][0], r[-1][1] - r[0][1]] for r in rows])
    ang = np.arctan2(ends[:, 1], ends[:, 0])
    ln = np.hypot(ends[:, 0], ends[:, 1])
    d = math.degrees(0.5 * math.atan2(float((ln * np.sin(2 * ang)).sum()), float((ln * np.cos(2 * ang)).sum())))
    return round(d % 180.0, 3) % 180.0  # 179.9996 -> 0.0


def _confidence(found: list[_Found], spacing: float, strength: float, lengths: list[float]) -> float:
    """Support x regularity x strength factor, in [0, 1]: length-weighted row support, 1 - 2 x the mean
    deviation of neighbour distances from a whole number of spacings, min(1, log10(strength) / 4)."""
    total = sum(lengths) or 1.0
    support = sum(f.support * ln for f, ln in zip(found, lengths, strict=True)) / total
    devs = []
    for a, b in zip(found[:-1], found[1:], strict=True):
        lo_t, hi_t = max(a.t[0], b.t[0]), min(a.t[-1], b.t[-1])
        tm = (lo_t + hi_t) / 2 if hi_t > lo_t else (a.t[0] + a.t[-1]) / 2
        d = abs(float(np.interp(tm, b.t, b.s) - np.interp(tm, a.t, a.s))) / spacing
        devs.append(abs(d - round(d)) if round(d) >= 1 else 0.5)
    regularity = 1.0 - 2.0 * float(np.mean(devs)) if devs else 0.5
    strength_f = min(1.0, math.log10(max(strength, 1.0)) / 4.0)
    return round(max(0.0, support * regularity * strength_f), 3)


def row_spacing_m(rows: Sequence[Polyline]) -> float:
    """Median distance between the midpoints of neighbouring rows (sorted across them), m; NaN for < 2 rows."""
    return row_spacing(rows)
