"""The canopy of every row, segment by segment, measured on a surface model (DSM); docs/dose.md. SI, world ENU.

Each row is sampled every ``step_m`` along it and across it over one row spacing (± s/2). At each along
position:

* the ground is the lowest surface in the outer band on either side (|a| >= 0.35 s, the middle of the
  inter-rows), a straight line between the two sides (a cross slope stays out of the canopy), median-filtered
  over 1 m along the row;
* the canopy height model is the surface minus that ground; the canopy *top* is its highest value in the
  row's own band (|a| <= 0.45 s);
* the canopy's cross-section is the canopy height model integrated across where it stands out (above 5 % of
  the top, one sample more on either side), m²; the *width* is that cross-section over the top: exact for a
  hedge of rectangular section, the rectangle of equal section otherwise;
* the leaf wall starts at the foliage *base* (a parameter per row: a DSM cannot see under the leaves) and ends
  at the top; the foliage volume is width x wall height along the segment;
* canopy is present where the wall is higher than ``gap_share`` (25 %) of the row's median wall (and 5 cm).

Absences at least ``gap_min_m`` long are *gaps* (missing vines) and become segments of their own; shorter
ones stay in the canopy. Every stretch of canopy is cut into equal segments of about ``segment_m`` (1-5 m).
A segment carries its along-row interval (m from the row's first point), its ENU end points, the median top
and width over its canopy samples, its cover (share of its length with canopy) and its foliage volume (m³);
its leaf wall area and tree-row volume per hectare follow (:mod:`vinecli.rows.dose_units`), scaled by the
cover. :func:`hedge_segments` gives the same structure for a world whose canopy is given, not measured.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from vinecli.rows.dose_units import lwa_m2_per_ha, trv_m3_per_ha

__all__ = ["CANOPY_SEGMENTS_SCHEMA", "CanopySegment", "CanopySegments", "Sampling", "hedge_segments", "plain_segments", "row_stations",
           "segment_canopy", "summary_text"]

CANOPY_SEGMENTS_SCHEMA = "vinecli.canopy_segments/1"
HeightFn = Callable[[np.ndarray, np.ndarray], np.ndarray]
Polyline = Sequence[tuple[float, float]]

#: bands across a row, as shares of the row spacing: ground at |a| >= GROUND_BAND s, the row's own at <= OWN_BAND s
GROUND_BAND = 0.35
OWN_BAND = 0.45
#: a wall lower than this is no canopy, m
MIN_WALL_M = 0.05


@dataclass(frozen=True)
class CanopySegment:
    """One segment of a row: along-row ``s0_m``..``s1_m`` (m from the row's first point), ENU end points,
    ``gap`` (no canopy), canopy ``top_m`` and foliage ``base_m`` above the ground (m), ``width_m``, ``cover``
    (0-1, share of its length with canopy), ``volume_m3`` (foliage above the base), ``spacing_m`` of the rows."""

    row: int
    s0_m: float
    s1_m: float
    start_enu: tuple[float, float]
    end_enu: tuple[float, float]
    gap: bool
    top_m: float
    base_m: float
    width_m: float
    cover: float
    volume_m3: float
    spacing_m: float

    @property
    def length_m(self) -> float:
        return self.s1_m - self.s0_m

    @property
    def wall_height_m(self) -> float:
        """Leaf-wall height (top - base), m; 0 in a gap."""
        return 0.0 if self.gap else max(self.top_m - self.base_m, 0.0)

    def lwa_m2pha(self, sides: int = 2) -> float:
        """Leaf wall area of this segment's canopy, m² per ha of ground, scaled by its cover (0 in a gap)."""
        return lwa_m2_per_ha(self.spacing_m, self.wall_height_m, sides) * self.cover if not self.gap else 0.0

    def trv_m3pha(self) -> float:
        """Tree-row volume of this segment's canopy, m³ per ha of ground, scaled by its cover (0 in a gap)."""
        return trv_m3_per_ha(self.spacing_m, self.wall_height_m, self.width_m) * self.cover if not self.gap else 0.0

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["start_enu"], d["end_enu"] = list(self.start_enu), list(self.end_enu)
        d.update(wall_height_m=self.wall_height_m, lwa_m2pha=self.lwa_m2pha(), trv_m3pha=self.trv_m3pha())
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> CanopySegment:
        names = cls.__dataclass_fields__
        kw = {k: v for k, v in d.items() if k in names}
        kw["start_enu"], kw["end_enu"] = tuple(d["start_enu"]), tuple(d["end_enu"])
        return cls(**kw)


@dataclass(frozen=True)
class CanopySegments:
    """Every row's segments in order (row, then along it); ``source`` "dsm" (measured) or "hedges" (given)."""

    segments: tuple[CanopySegment, ...]
    spacing_m: float
    segment_m: float
    source: str
    step_m: float = math.nan

    def for_row(self, row: int) -> list[CanopySegment]:
        return [g for g in self.segments if g.row == row]

    def summary(self) -> dict[str, Any]:
        """Counts and length-weighted means over the canopy (not the gaps): wall height, width, LWA (both
        sides), TRV; total gap length and foliage volume."""
        canopy = [g for g in self.segments if not g.gap]
        lengths = np.array([g.length_m for g in canopy]) if canopy else np.zeros(0)

        def mean(vals: list[float]) -> float:
            return float(np.average(vals, weights=lengths)) if canopy and lengths.sum() > 0 else 0.0

        return {"segments": len(self.segments), "rows": len({g.row for g in self.segments}),
                "segment_m": self.segment_m, "spacing_m": self.spacing_m, "source": self.source,
                "gaps": sum(g.gap for g in self.segments),
                "gap_length_m": float(sum(g.length_m for g in self.segments if g.gap)),
                "canopy_length_m": float(lengths.sum()),
                "wall_height_m": mean([g.wall_height_m for g in canopy]), "width_m": mean([g.width_m for g in canopy]),
                "lwa_m2pha": mean([g.lwa_m2pha() for g in canopy]), "trv_m3pha": mean([g.trv_m3pha() for g in canopy]),
                "volume_m3": float(sum(g.volume_m3 for g in self.segments))}

    def summary_line(self) -> str:
        """One line for ``world build`` and ``terrain info``."""
        return summary_text(self.summary())

    def to_dict(self) -> dict[str, Any]:
        return {"schema": CANOPY_SEGMENTS_SCHEMA, "spacing_m": self.spacing_m, "segment_m": self.segment_m,
                "source": self.source, "step_m": self.step_m, "summary": self.summary(),
                "segments": [g.to_dict() for g in self.segments]}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> CanopySegments:
        if d.get("schema") != CANOPY_SEGMENTS_SCHEMA:
            raise ValueError(f"not {CANOPY_SEGMENTS_SCHEMA}: schema {d.get('schema')!r}")
        return cls(tuple(CanopySegment.from_dict(g) for g in d["segments"]), float(d["spacing_m"]),
                   float(d["segment_m"]), str(d["source"]), float(d.get("step_m") or math.nan))


def summary_text(s: dict[str, Any]) -> str:
    """One line of a :meth:`CanopySegments.summary`."""
    return (f"{s['segments']} segments of ~{s['segment_m']:g} m on {s['rows']} rows ({s['source']}): wall "
            f"{s['wall_height_m']:.2f} m high, {s['width_m']:.2f} m wide, LWA {s['lwa_m2pha']:,.0f} m²/ha "
            f"(both sides), TRV {s['trv_m3pha']:,.0f} m³/ha, {s['gaps']} gaps ({s['gap_length_m']:.1f} m)")


def row_stations(line: Polyline, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 2) and unit directions (n, 2) at along-row distances ``s`` (m from the first point)."""
    pts = np.asarray(line, dtype=np.float64)
    seg = np.diff(pts, axis=0)
    lens = np.hypot(seg[:, 0], seg[:, 1])
    cum = np.concatenate([[0.0], np.cumsum(lens)])
    k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(lens) - 1)
    safe = np.where(lens[k] > 0, lens[k], 1.0)
    t = (np.asarray(s, dtype=np.float64) - cum[k]) / safe
    return pts[k] + seg[k] * t[:, None], seg[k] / safe[:, None]


def _point(line: Polyline, s: float) -> tuple[float, float]:
    p, _ = row_stations(line, np.array([s]))
    return (round(float(p[0, 0]), 4), round(float(p[0, 1]), 4))


def _runs(flags: np.ndarray) -> list[tuple[int, int, bool]]:
    """Maximal runs (start, end exclusive, value) of a boolean array."""
    if flags.size == 0:
        return []
    cuts = np.flatnonzero(np.diff(flags.astype(np.int8))) + 1
    bounds = [0, *cuts.tolist(), flags.size]
    return [(a, b, bool(flags[a])) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def _stretches(present: np.ndarray, min_gap: int) -> list[tuple[int, int, bool]]:
    """(start, end, gap) stretches of a row's samples: absences of at least ``min_gap`` samples are gaps, shorter
    ones belong to the canopy around them."""
    out: list[tuple[int, int, bool]] = []
    for a, b, here in _runs(present):
        gap = not here and b - a >= min_gap
        if out and out[-1][2] == gap:
            out[-1] = (out[-1][0], b, gap)
        else:
            out.append((a, b, gap))
    return out


def _profile(height: HeightFn, line: Polyline, n: int, ds: float, spacing: float, da_target: float
             ) -> tuple[np.ndarray, np.ndarray, float]:
    """Canopy height model across the row at ``n`` along stations: (chm (n, m), across offsets (m,), da)."""
    half = 0.5 * spacing
    m = 2 * max(4, math.ceil(half / da_target)) + 1
    a = np.linspace(-half, half, m)
    p, d = row_stations(line, (np.arange(n) + 0.5) * ds)
    nrm = np.stack([-d[:, 1], d[:, 0]], axis=1)
    xs = p[:, 0:1] + a[None, :] * nrm[:, 0:1]
    ys = p[:, 1:2] + a[None, :] * nrm[:, 1:2]
    z = np.asarray(height(xs.ravel(), ys.ravel()), dtype=np.float64).reshape(n, m)
    z[~np.isfinite(z)] = np.nan
    left, right = a <= -GROUND_BAND * spacing, a >= GROUND_BAND * spacing
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN stations (off the DSM) stay NaN
        gl, gr = np.nanmin(z[:, left], axis=1), np.nanmin(z[:, right], axis=1)
    gl, gr = _smooth_ground(gl, ds), _smooth_ground(gr, ds)
    ac = 0.5 * (GROUND_BAND + 0.5) * spacing  # the middle of each ground band
    ground = 0.5 * (gl + gr)[:, None] + ((gr - gl) / (2 * ac))[:, None] * a[None, :]
    return z - ground, a, float(a[1] - a[0])


def _smooth_ground(g: np.ndarray, ds: float) -> np.ndarray:
    """Ground heights along a row with holes filled by the row's median and a 1 m running median."""
    from scipy.ndimage import median_filter

    if not np.any(np.isfinite(g)):
        return g
    g = np.where(np.isfinite(g), g, np.nanmedian(g))
    return np.asarray(median_filter(g, size=max(1, int(round(1.0 / ds)) | 1), mode="nearest"))


def _section(chm: np.ndarray, top: np.ndarray) -> np.ndarray:
    """Per station, the canopy height model integrated across where the canopy stands out (above 5 % of its top,
    one sample more on either side: the whole edge of a hedge, not the ground's roughness beside it), m x samples."""
    out = chm > 0.05 * top[:, None]
    out[:, 1:] |= out[:, :-1].copy()
    out[:, :-1] |= out[:, 1:].copy()
    return np.sum(np.where(out, np.clip(chm, 0.0, None), 0.0), axis=1)


@dataclass(frozen=True)
class Sampling:
    """How :func:`segment_canopy` samples a row and finds its gaps (module docstring): every ``step_m`` along it
    and every ``across_step_m`` across it (None: a 32nd of the row spacing), m; canopy present where the wall is
    higher than ``gap_share`` of the row's median wall; absences at least ``gap_min_m`` long are gaps, m."""

    step_m: float = 0.1
    across_step_m: float | None = None
    gap_min_m: float = 0.5
    gap_share: float = 0.25


def segment_canopy(height: HeightFn, rows: Sequence[Polyline], *, spacing_m: float,
                   base_m: float | Sequence[float], segment_m: float = 2.0,
                   sampling: Sampling = Sampling()) -> CanopySegments:
    """Every row's segments measured on the surface ``height(x, y)`` (m, any vertical datum; NaN = no data);
    see the module docstring. ``base_m``: foliage base above the ground, one for all rows or one per row."""
    step_m, across_step_m, gap_min_m, gap_share = (sampling.step_m, sampling.across_step_m, sampling.gap_min_m,
                                                   sampling.gap_share)
    if not (math.isfinite(spacing_m) and spacing_m > 0):
        raise ValueError(f"row spacing must be > 0 m, got {spacing_m!r}")
    if not 0.5 <= segment_m <= 50:
        raise ValueError(f"segment length must be 0.5-50 m, got {segment_m!r}")
    bases = [float(base_m)] * len(rows) if isinstance(base_m, (int, float)) else [float(b) for b in base_m]
    da = across_step_m if across_step_m is not None else spacing_m / 32.0
    out: list[CanopySegment] = []
    for i, line in enumerate(rows):
        total = float(np.sum(np.hypot(*np.diff(np.asarray(line, dtype=np.float64), axis=0).T))) if len(line) >= 2 else 0.0
        if total <= 0.0:
            continue
        n = max(1, math.ceil(total / step_m))
        ds = total / n
        chm, a, da_ = _profile(height, line, n, ds, spacing_m, da)
        own = np.abs(a) <= OWN_BAND * spacing_m
        base = bases[i]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            top = np.nan_to_num(np.nanmax(np.where(own[None, :], chm, np.nan), axis=1), nan=0.0)
        area = _section(np.nan_to_num(chm[:, own], nan=0.0), top) * da_  # the canopy's cross-section, m²
        wall = top - base
        cand = wall > MIN_WALL_M
        ref = float(np.median(wall[cand])) if np.any(cand) else 0.0
        present = wall > max(MIN_WALL_M, gap_share * ref)
        width = np.where(present, area / np.where(top > 0, top, 1.0), 0.0)
        for a0, a1, gap in _stretches(present, max(1, int(round(gap_min_m / ds)))):
            pieces = 1 if gap else max(1, int(round((a1 - a0) * ds / segment_m)))
            cuts = np.round(np.linspace(a0, a1, pieces + 1)).astype(int)
            for k0, k1 in zip(cuts[:-1], cuts[1:], strict=True):
                pres = present[k0:k1]
                s0, s1 = k0 * ds, k1 * ds
                has = bool(np.any(pres))
                out.append(CanopySegment(
                    row=i, s0_m=round(s0, 4), s1_m=round(s1, 4), start_enu=_point(line, s0), end_enu=_point(line, s1),
                    gap=gap, top_m=float(np.median(top[k0:k1][pres])) if has else float(np.median(top[k0:k1])),
                    base_m=base, width_m=float(np.median(width[k0:k1][pres])) if has and not gap else 0.0,
                    cover=float(np.mean(pres)),
                    volume_m3=0.0 if gap else float(np.sum((width * np.clip(wall, 0.0, None))[k0:k1][pres]) * ds),
                    spacing_m=float(spacing_m)))
    return CanopySegments(tuple(out), float(spacing_m), float(segment_m), "dsm", float(step_m))


def hedge_segments(rows: Sequence[Polyline], hedges: Sequence[Any], spacing_m: float, segment_m: float = 2.0
                   ) -> CanopySegments:
    """Segments of rows whose canopy is given (each hedge's ``row``, ``base_m``, ``top_m``, ``width_m``, as
    :class:`vinecli.spray.canopy.Hedge`): uniform along each row, no gaps, cover 1."""
    by_row = {int(h.row): h for h in hedges}
    out: list[CanopySegment] = []
    for i, line in enumerate(rows):
        h = by_row.get(i)
        total = float(np.sum(np.hypot(*np.diff(np.asarray(line, dtype=np.float64), axis=0).T))) if len(line) >= 2 else 0.0
        if h is None or total <= 0.0:
            continue
        pieces = max(1, int(round(total / segment_m)))
        edges = np.linspace(0.0, total, pieces + 1)
        wall = max(float(h.top_m) - float(h.base_m), 0.0)
        gap = wall <= 0.0 or float(h.width_m) <= 0.0
        for s0, s1 in zip(edges[:-1], edges[1:], strict=True):
            out.append(CanopySegment(
                row=i, s0_m=round(float(s0), 4), s1_m=round(float(s1), 4), start_enu=_point(line, float(s0)),
                end_enu=_point(line, float(s1)), gap=gap, top_m=float(h.top_m), base_m=float(h.base_m),
                width_m=0.0 if gap else float(h.width_m), cover=0.0 if gap else 1.0,
                volume_m3=0.0 if gap else wall * float(h.width_m) * float(s1 - s0), spacing_m=float(spacing_m)))
    return CanopySegments(tuple(out), float(spacing_m), float(segment_m), "hedges")



def plain_segments(rows: Sequence[Polyline], spacing_m: float, segment_m: float = 2.0) -> CanopySegments:
    """Segments of rows whose canopy is unknown (no surface model, no canopy given): uniform, no gaps, no
    measures (a rate or a prescription map applies to them; a dose per LWA or TRV cannot)."""
    out: list[CanopySegment] = []
    for i, line in enumerate(rows):
        total = float(np.sum(np.hypot(*np.diff(np.asarray(line, dtype=np.float64), axis=0).T))) if len(line) >= 2 else 0.0
        if total <= 0.0:
            continue
        edges = np.linspace(0.0, total, max(1, int(round(total / segment_m))) + 1)
        out += [CanopySegment(row=i, s0_m=round(float(a), 4), s1_m=round(float(b), 4), start_enu=_point(line, float(a)),
                              end_enu=_point(line, float(b)), gap=False, top_m=0.0, base_m=0.0, width_m=0.0, cover=1.0,
                              volume_m3=0.0, spacing_m=float(spacing_m)) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    return CanopySegments(tuple(out), float(spacing_m), float(segment_m), "rows")


def coarsen(canopy: CanopySegments, segment_m: float) -> CanopySegments:
    """``canopy`` with each stretch of canopy between gaps merged into about equal segments of ``segment_m`` (m):
    whole segments joined, their measures length-weighted (volume summed); gaps kept. Unchanged when
    ``segment_m`` is not longer than its segments."""
    if segment_m <= canopy.segment_m * 1.25:
        return canopy
    out: list[CanopySegment] = []
    run: list[CanopySegment] = []

    def flush() -> None:
        if not run:
            return
        total = run[-1].s1_m - run[0].s0_m
        n = max(1, int(round(total / segment_m)))
        groups: dict[int, list[CanopySegment]] = {}
        for g in run:
            k = min(n - 1, int((0.5 * (g.s0_m + g.s1_m) - run[0].s0_m) / (total / n)))
            groups.setdefault(k, []).append(g)
        for part in groups.values():
            w = np.array([g.length_m for g in part])

            def mean(vals: list[float], w: np.ndarray = w) -> float:
                return float(np.average(vals, weights=w)) if w.sum() > 0 else float(vals[0])

            out.append(CanopySegment(part[0].row, part[0].s0_m, part[-1].s1_m, part[0].start_enu, part[-1].end_enu,
                                     False, mean([g.top_m for g in part]), mean([g.base_m for g in part]),
                                     mean([g.width_m for g in part]), mean([g.cover for g in part]),
                                     float(sum(g.volume_m3 for g in part)), part[0].spacing_m))
        run.clear()

    for g in canopy.segments:
        if g.gap or (run and g.row != run[-1].row):
            flush()
        if g.gap:
            out.append(g)
        else:
            run.append(g)
    flush()
    return replace(canopy, segments=tuple(out), segment_m=float(segment_m))
