"""Where each pass of a spray plan flies (ENU m), for :func:`vinecli.rows.plan.plan_rows`: rows clipped to a region
(:func:`clip_rows`), the passes laid out over them from the sprayer's pattern (:func:`lay_passes`: one per lane of
:func:`~vinecli.rows.lanes.layout_lanes`; rows cut into stretches by a no-spray zone get a pass per stretch and
none over the gap, :mod:`vinecli.rows.stretches`) and run on past the row ends (:func:`extend_pass`); every pass
closes its sections the footprint's clearance before a no-spray zone (``blocked``, :mod:`vinecli.rows.no_spray`).
"""

from __future__ import annotations

import math

from vinecli.geometry import polyline_length
from vinecli.rows.detect import Polyline
from vinecli.rows.lanes import LaneLayout, lane_polyline, layout_lanes
from vinecli.rows.no_spray import pass_pieces
from vinecli.rows.stretches import SAME_LINE_M, cut_path, line_spans, merge_spans, row_lines

__all__ = ["Pass", "clip_rows", "extend_pass", "lay_passes", "room_ahead"]

Point = tuple[float, float]


def clip_rows(rows: list[Polyline], region: object, what: str, warnings: list[str]) -> list[Polyline]:
    """Rows clipped to a shapely polygon (longest piece kept, [] when none: the list stays aligned with the
    input); one warning line when any row leaves it."""
    from shapely.geometry import LineString

    out: list[Polyline] = []
    cut = 0.0
    n_out = 0
    for r in rows:
        if len(r) < 2:
            out.append([])
            continue
        line = LineString(r)
        piece = line.intersection(region)  # type: ignore[arg-type]
        parts = [g for g in getattr(piece, "geoms", [piece]) if g.geom_type == "LineString" and not g.is_empty]
        if not parts:  # wholly outside: kept as an empty row so the indices stay aligned
            n_out += 1
            cut = max(cut, line.length)
            out.append([])
            continue
        best = max(parts, key=lambda g: g.length)
        if line.length - best.length > 0.05:
            n_out += 1
            cut = max(cut, line.length - best.length)
        pts = [(float(x), float(y)) for x, y in best.coords]
        # keep the row's own direction
        if math.dist(pts[0], r[0]) > math.dist(pts[-1], r[0]):
            pts = pts[::-1]
        out.append(pts)
    if n_out:
        warnings.append(f"{n_out} of {len(rows)} rows leave the {what}: clipped (up to {cut:.1f} m cut from a row)")
    return out


def room_ahead(p: Point, d: tuple[float, float], inner: object | None, limit: float) -> float:
    """How far (m, up to ``limit``) one can go from ``p`` along the unit vector ``d`` inside ``inner`` (0.05 m steps)."""
    if not math.isfinite(limit) or limit < 0.0:
        raise ValueError(f"room_ahead: limit {limit!r} m is not a finite distance")
    if inner is None:
        return limit
    from shapely.geometry import Point as P

    if not inner.contains(P(p)):  # type: ignore[attr-defined]
        return 0.0
    lo, hi = 0.0, limit
    if inner.contains(P(p[0] + d[0] * hi, p[1] + d[1] * hi)):  # type: ignore[attr-defined]
        return hi
    while hi - lo > 0.05:
        mid = 0.5 * (lo + hi)
        if inner.contains(P(p[0] + d[0] * mid, p[1] + d[1] * mid)):  # type: ignore[attr-defined]
            lo = mid
        else:
            hi = mid
    return lo


def extend_pass(path: Polyline, pattern: object, inner: object | None, margin: float,
            ends: tuple[bool, bool] = (True, True)) -> list[tuple[float, float]]:
    """``path`` run on straight past both ends (those ``ends`` flags) so that the deposit reaches its full rate at
    them: by the footprint radius, less / plus the drops' landing offset ahead of the nozzles, plus ``margin``
    (within ``inner``)."""
    foot = float(getattr(pattern, "footprint_radius_m", 0.0)) + margin
    ahead = float(getattr(pattern, "along_offset_m", 0.0))
    pts = [(float(x), float(y)) for x, y in path]
    for end, extra in ((0, foot + ahead if ends[0] else 0.0), (-1, foot - ahead if ends[1] else 0.0)):
        p, q = (pts[0], pts[1]) if end == 0 else (pts[-1], pts[-2])
        dx, dy = p[0] - q[0], p[1] - q[1]
        n = math.hypot(dx, dy)
        if n <= 0.0 or extra <= 0.0:
            continue
        d = (dx / n, dy / n)
        e = room_ahead(p, d, inner, extra)
        if e > 0.01:
            new = (p[0] + d[0] * e, p[1] + d[1] * e)
            pts = [new, *pts] if end == 0 else [*pts, new]
    return pts


Pass = tuple[int, int | None, Polyline]  # lane index, row flown over or None, path


def lay_passes(keep: list[tuple[int, Polyline]], u: tuple[float, float], pattern: object | None, band_m: float,
            inner: object | None, warnings: list[str], end_margin: float = 0.0, blocked: object | None = None
            ) -> tuple[list[Pass], LaneLayout | None]:
    """(lane index, row flown over or None, path) of every pass piece, and the layout (None: a pass per row);
    the pieces of a pass lie outside ``blocked`` (the no-spray zones grown by the clearance), in order along it."""
    if pattern is None:
        return [(i, i, c) for i, r in keep for c in pass_pieces(r, blocked)], None
    normal = (-u[1], u[0])
    across = _across(keep, normal)
    lines = row_lines(across, [r for _, r in keep], u)
    if any(len(ln) > 1 for ln in lines):  # rows cut into stretches: a pass per stretch, none over the gaps
        return _cutlay_passes(keep, lines, u, pattern, band_m, inner, end_margin, blocked)
    lay = layout_lanes(across, pattern, band_m)
    out: list[Pass] = []
    cut = 0
    for k, c in enumerate(lay.across_m):
        near = min(range(len(keep)), key=lambda j: abs(across[j] - c))
        path = [r for _, r in keep][near] if abs(across[near] - c) < 1e-6 else lane_polyline(
            [r for _, r in keep], across, c, normal)
        if inner is not None:
            clipped = clip_rows([path], inner, "", [])[0]
            cut += len(clipped) >= 2 and abs(polyline_length(clipped) - polyline_length(path)) > 0.05
            path = clipped
        if len(path) >= 2:
            row = keep[near][0] if abs(across[near] - c) < 0.05 else None
            out += [(k, row, q) for q in pass_pieces(extend_pass(path, pattern, inner, end_margin), blocked)]
    if cut:
        warnings.append(f"{cut} of {len(lay.across_m)} passes beyond the outer rows leave the fence: clipped")
    return out, lay


def _across(keep: list[tuple[int, Polyline]], normal: tuple[float, float]) -> list[float]:
    """Each kept row's mean position across the rows (along ``normal``), m."""
    return [sum(normal[0] * x + normal[1] * y for x, y in r) / len(r) for _, r in keep]


def _cutlay_passes(keep: list[tuple[int, Polyline]], lines: list[list[int]], u: tuple[float, float], pattern: object,
                   band_m: float, inner: object | None, end_margin: float, blocked: object | None
                   ) -> tuple[list[Pass], LaneLayout]:
    """:func:`_passes` for rows cut into stretches (:mod:`vinecli.rows.stretches`): the layout over the row lines; a
    pass on a line flies each of its stretches, a pass between lines the spans where either neighbour has canopy;
    runs on past the lines' outer ends only."""
    normal = (-u[1], u[0])
    across = _across(keep, normal)
    paths = [r for _, r in keep]
    line_across = [sum(across[j] for j in ln) / len(ln) for ln in lines]
    hulls = [[p for j in ln for p in (paths[j] if _along_sign(paths[j], u) else paths[j][::-1])] for ln in lines]
    lay = layout_lanes(line_across, pattern, band_m)
    out: list[Pass] = []
    pieces: list[tuple[int | None, Polyline, bool, bool]]
    for k, c in enumerate(lay.across_m):
        near = min(range(len(lines)), key=lambda j: abs(line_across[j] - c))
        if abs(line_across[near] - c) < SAME_LINE_M:
            spans = line_spans(lines[near], paths, u)
            pieces = [(keep[j][0], piece, a, b) for j in lines[near]
                      for piece, a, b in cut_path(lane_polyline([paths[j]], [across[j]], c, normal), spans, u)]
        else:
            nb = sorted(range(len(lines)), key=lambda j: abs(line_across[j] - c))[:2]
            if not min(line_across[j] for j in nb) <= c <= max(line_across[j] for j in nb):
                nb = nb[:1]  # beyond the outer line: its spans alone
            spans = merge_spans([sp for j in nb for sp in line_spans(lines[j], paths, u)])
            pieces = [(None, piece, a, b) for piece, a, b in cut_path(lane_polyline(hulls, line_across, c, normal),
                                                                      spans, u)]
        for row, piece, a, b in pieces:
            path = clip_rows([piece], inner, "", [])[0] if inner is not None else piece
            if len(path) >= 2:
                out += [(k, row, q) for q in pass_pieces(extend_pass(path, pattern, inner, end_margin, (a, b)), blocked)]
    return out, lay


def _along_sign(path: Polyline, u: tuple[float, float]) -> bool:
    return (path[-1][0] - path[0][0]) * u[0] + (path[-1][1] - path[0][1]) * u[1] >= 0
