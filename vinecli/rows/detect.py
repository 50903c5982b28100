"""Crop/vine row detection on a regular height grid (local metres: x east, y north; heights m).

The one row detector of vinecli (``world build`` with ``rows: auto``, ``plan rows`` and the run-time
detection all call :func:`detect_rows_grid`). Deterministic; steps:

1. dominant row direction and spacing from the 2-D spectrum of the plane-detrended heights
   (:mod:`~vinecli.rows.spectrum`);
2. canopy relief = heights minus a NaN-aware Gaussian background (sigma = one spacing): slopes and
   terrain undulations drop out, rows stand out;
3. the field is cut into strips along the rows (about 1.5 spacings long); each strip's mean relief
   profile across the rows gives row peaks (:func:`scipy.signal.find_peaks`, prominence at least
   ``min_prominence`` x the field's 90th percentile), each placed where along the strip its relief is;
4. peaks are linked strip to strip into rows along the local row slope (first from each strip's
   gradient structure tensor, then from the rows found), within 0.3 spacing, canopy gaps up to
   ``max_gap_m`` bridged; later passes de-skew every strip by that slope so curved rows stay sharp
   (:mod:`~vinecli.rows.track`);
5. each row's centre line is a cubic spline through its peaks, extended straight on and trimmed to
   where the canopy ends (relief at least half the row's median, data on both sides of the line), an
   end beyond the last strip peak located from the cells there, simplified to 2 cm (Douglas-Peucker).

Directions are angles in degrees from east (x), counter-clockwise, folded to [0, 180) (the rows' mean
direction); every row polyline runs along it; rows are numbered from west (rows running north-south)
or from south (rows running east-west).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vinecli.errors import TerrainError
from vinecli.physics.canopy import row_spacing
from vinecli.rows.geometry import polyline_length
from vinecli.rows.spectrum import decimate, direction_and_spacing, fill_and_detrend, gradients, relief_of
from vinecli.rows.track import (
    Strips,
    chain_skew,
    make_strips,
    strip_peaks,
    strip_profiles,
    tensor_skew,
    track_peaks,
)

Polyline = list[tuple[float, float]]

__all__ = ["Polyline", "RowDetection", "detect_rows_grid"]


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
                "rows_enu": [[list(p) for p in r] for r in self.rows]}


# ---------------------------------------------------------------- rows as polylines
def _line(t: np.ndarray, s: np.ndarray, extend: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """(t, s) every ``step`` m through knots (t, s): a cubic spline, extended ``extend`` m at both ends
    straight on along the end slope of a quadratic fit of the last five knots (trimmed later)."""
    from scipy.interpolate import CubicSpline

    order = np.argsort(t)
    t, s = t[order], s[order]
    keep = np.concatenate([[True], np.diff(t) > 1e-6])
    t, s = t[keep], s[keep]
    tt = np.arange(t[0] - extend, t[-1] + extend + step / 2, step)
    if s.size >= 4:
        cs = CubicSpline(t, s)
        inner = np.clip(tt, t[0], t[-1])
        deg = 2 if s.size >= 5 else 1
        g0 = np.polyval(np.polyder(np.polyfit(t[:5], s[:5], deg)), t[0])
        g1 = np.polyval(np.polyder(np.polyfit(t[-5:], s[-5:], deg)), t[-1])
        return tt, cs(inner) + np.where(tt < t[0], g0, g1) * (tt - inner)
    g = np.polyfit(t, s, 1) if s.size >= 2 else np.array([0.0, s[0]])  # two or three knots: a straight line
    return tt, np.polyval(g, tt)


@dataclass
class _Cells:
    """Field cells sorted along the rows: ``t`` (m, ascending), ``s`` (m), relief ``h`` (m)."""

    t: np.ndarray
    s: np.ndarray
    h: np.ndarray


def _end_knot(cells: _Cells, tl: np.ndarray, sl: np.ndarray, t0: float, t1: float, spacing: float
              ) -> tuple[float, float] | None:
    """A knot for a row end beyond the last strip peak: relief-weighted centroid of the cells within
    ``[t0, t1]`` and half a spacing of the line (tl, sl)."""
    i0, i1 = np.searchsorted(cells.t, [min(t0, t1), max(t0, t1)])
    t, s, h = cells.t[i0:i1], cells.s[i0:i1], cells.h[i0:i1]
    if t.size == 0:
        return None
    d = s - np.interp(t, tl, sl)
    w = np.where(np.abs(d) < spacing / 2, np.maximum(h, 0.0), 0.0) ** 2
    if w.sum() <= 0:
        return None
    tm = float((w * t).sum() / w.sum())
    return tm, float(np.interp(tm, tl, sl) + (w * d).sum() / w.sum())


def _row_line(c: list[tuple[int, float, float]], cells: _Cells, st: Strips, to_xy: Any, relief: np.ndarray,
              x: np.ndarray, y: np.ndarray, spacing: float, step: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Centre line (t, s) of a chain of strip peaks, ends where the row ends; an end more than a quarter
    strip beyond the last peak gets one more knot from the cells there (partial strips at the row ends)."""
    kt = np.array([q[1] for q in c])
    ks = np.array([q[2] for q in c])
    tl, sl = _line(kt, ks, st.length, step)
    trimmed = _trim_ends(tl, sl, to_xy, relief, x, y, spacing)
    if trimmed is None:
        return None
    ta, tb = float(trimmed[0][0]), float(trimmed[0][-1])
    extra = []
    if kt.min() - ta > st.length / 4:
        extra.append(_end_knot(cells, tl, sl, ta, kt.min() - st.length / 4, spacing))
    if tb - kt.max() > st.length / 4:
        extra.append(_end_knot(cells, tl, sl, kt.max() + st.length / 4, tb, spacing))
    extra = [e for e in extra if e is not None]
    if extra:
        kt = np.concatenate([kt, [e[0] for e in extra]])
        ks = np.concatenate([ks, [e[1] for e in extra]])
        tl, sl = _line(kt, ks, st.length, step)
    keep = (tl >= ta - step / 2) & (tl <= tb + step / 2)
    return tl[keep], sl[keep]


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
    (default: 3 spacings or two strips) are dropped; gaps in a row up to ``max_gap_m`` are bridged. Grids
    larger than ``max_cells`` are block-averaged first. ``confidence`` = support (length-weighted fraction
    of strips where each row was seen) x regularity (1 - 2 x mean deviation of neighbour distances from a
    whole number of spacings) x min(1, log10(strength) / 4) (clear rows: strength > 10^4).
    """
    z = np.asarray(z, dtype=float)
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if z.shape != (y.size, x.size) or x.size < 8 or y.size < 8:
        raise TerrainError(f"height grid must be at least 8x8 and match x, y (got {z.shape})")
    z, x, y = decimate(z, x, y, max_cells)
    zz, valid = fill_and_detrend(z)
    lo, hi = (spacing_m * 0.75, spacing_m * 1.25) if spacing_m else (min_spacing_m, max_spacing_m)
    nvec, spacing, strength = direction_and_spacing(zz, valid, x, y, lo, hi)
    cell = min(abs(float(x[1] - x[0])), abs(float(y[1] - y[0])))
    relief = relief_of(np.where(valid, z, np.nan), valid, spacing / cell)
    gx, gy, gmask = gradients(relief, valid, spacing / 6 / cell)
    u = np.array([-nvec[1], nvec[0]])
    if math.atan2(u[1], u[0]) < -1e-9 or math.atan2(u[1], u[0]) >= math.pi - 1e-9:
        u = -u
    n = np.array([-u[1], u[0]])  # left normal of u
    direction = math.degrees(math.atan2(u[1], u[0])) % 180.0
    X, Y = np.meshgrid(x, y)
    h = relief[valid]
    s = X[valid] * n[0] + Y[valid] * n[1]
    t = X[valid] * u[0] + Y[valid] * u[1]
    st = make_strips(s, t, h, max(1.5 * spacing, 4 * cell), min(cell, spacing / 8))
    gap_strips = int(math.floor(max_gap_m / st.length))
    skew = tensor_skew(gx[valid], gy[valid], gmask[valid], st, n, u)
    for _ in range(3):  # later passes: strips de-skewed along the local row slope
        peaks = strip_peaks(strip_profiles(st, skew, spacing), st, skew, spacing, min_prominence)
        chains = track_peaks(peaks, spacing, gap_strips, skew)
        skew = chain_skew(chains, st)
    min_len = min_length_m if min_length_m is not None else max(3 * spacing, 2 * st.length)

    def to_xy(ss: np.ndarray, tt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return ss * n[0] + tt * u[0], ss * n[1] + tt * u[1]

    order = np.argsort(t, kind="stable")
    cells = _Cells(t[order], s[order], h[order])
    found: list[tuple[float, Polyline, float, np.ndarray, np.ndarray]] = []
    for c in chains:
        if len(c) < 2:
            continue
        line_ts = _row_line(c, cells, st, to_xy, relief, x, y, spacing, max(cell, 0.05))
        if line_ts is None or line_ts[0][-1] - line_ts[0][0] < min_len:
            continue
        tl, sl = line_ts
        px, py = to_xy(sl, tl)
        pts = _simplify(np.column_stack([px, py]), 0.02)
        line = [(round(float(a), 3), round(float(b), 3)) for a, b in pts]
        support = len(c) / (c[-1][0] - c[0][0] + 1)
        found.append((float(np.mean(sl)), line, support, tl, sl))
    order_sign = 1.0 if n[0] + n[1] >= 0 else -1.0  # number rows from west / south
    found.sort(key=lambda f: order_sign * f[0])
    rows = [f[1] for f in found]
    if rows:  # the rows' mean direction (length-weighted end-to-end, doubled angles): curved rows' mean
        ends = np.array([[r[-1][0] - r[0][0], r[-1][1] - r[0][1]] for r in rows])
        ang = np.arctan2(ends[:, 1], ends[:, 0])
        ln = np.hypot(ends[:, 0], ends[:, 1])
        direction = math.degrees(0.5 * math.atan2(float((ln * np.sin(2 * ang)).sum()),
                                                  float((ln * np.cos(2 * ang)).sum()))) % 180.0
    direction = round(direction, 3) % 180.0  # 179.9996 -> 0.0
    det = RowDetection(direction, round(spacing, 4), rows, round(strength, 2))
    det.support = [round(f[2], 3) for f in found]
    det.confidence = _confidence(found, spacing, strength, det.lengths_m)
    return det


def _confidence(found: list[tuple[float, Polyline, float, np.ndarray, np.ndarray]], spacing: float, strength: float,
                lengths: list[float]) -> float:
    """Support x regularity x strength factor, in [0, 1] (see :func:`detect_rows_grid`)."""
    if not found:
        return 0.0
    total = sum(lengths) or 1.0
    support = sum(f[2] * ln for f, ln in zip(found, lengths, strict=True)) / total
    devs = []
    for (_, _, _, ta, sa), (_, _, _, tb, sb) in zip(found[:-1], found[1:], strict=True):
        lo_t, hi_t = max(ta[0], tb[0]), min(ta[-1], tb[-1])
        tm = (lo_t + hi_t) / 2 if hi_t > lo_t else (ta[0] + ta[-1]) / 2
        d = abs(float(np.interp(tm, tb, sb) - np.interp(tm, ta, sa))) / spacing
        devs.append(abs(d - round(d)) if round(d) >= 1 else 0.5)
    regularity = 1.0 - 2.0 * float(np.mean(devs)) if devs else 0.5
    strength_f = min(1.0, math.log10(max(strength, 1.0)) / 4.0)
    return round(max(0.0, support * regularity * strength_f), 3)


def row_spacing_m(rows: Sequence[Polyline]) -> float:
    """Median distance between the midpoints of neighbouring rows (sorted across them), m; NaN for < 2 rows."""
    return row_spacing(rows)
