"""No-spray zones in a spray plan (ENU m): how far from a zone the sections close, and what the dose is judged on.

A grower's no-spray zone (a stream or a neighbour's plot, already grown by the grower's buffer) cuts the world's
rows into stretches (:func:`vinecli.world.gis_inputs.cut_rows`); the passes are laid out per stretch
(:mod:`vinecli.rows.stretches`, :mod:`vinecli.rows.passes`). A pass ending at the zone's edge still puts liquid in
it: the drops of a nozzle land within the footprint radius R of a point the along offset a ahead of the nozzles
(behind them when the pass flies away from the zone), and the pump runs down after the section closes. So:

* :func:`clearance_m`: how far from a zone a pass closes its sections so that no drop lands in it,
  ``g = R + |a| + end margin`` (the plan's ``end_margin_m`` = v x max(tau), the pump's ramp);
* :func:`pass_pieces`: a pass minus the zones grown by ``g`` (:func:`blocked_area`), the pieces in flight order;
* :func:`dosed_stretch`: the row stretch the dose is judged on. With the sections closed ``g`` before the zone,
  the deposit on the row tapers from the full rate to nothing over the last ``R + |a|`` before the point
  ``g - R - |a|`` from the zone (full rate needs the whole footprint to pass over a point): the full dose can only
  be asked up to ``taper_m = g + R + |a|`` from the zone. The stretch judged is the row piece less that taper at
  its zone end(s); a row passing beside a zone keeps its stretch with the taper as an unjudged hole
  (``deposition.json`` rows: ``planned_m``, ``not_judged_m``), so a reader tells it from a gap.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

__all__ = ["MIN_PIECE_M", "blocked_area", "clearance_m", "dosed_stretch", "pass_pieces", "taper_m"]

Point = tuple[float, float]
Polyline = list[Point]

#: pass pieces left between zones shorter than this are not flown with the sections open, m
MIN_PIECE_M = 0.5


def _reach(pattern: object | None) -> float:
    """R + |a| of a :class:`~vinecli.spray.swath.SwathPattern` (0 without one), m."""
    return float(getattr(pattern, "footprint_radius_m", 0.0)) + abs(float(getattr(pattern, "along_offset_m", 0.0)))


def clearance_m(pattern: object | None, end_margin_m: float) -> float:
    """Distance from a zone at which a pass closes its sections (module doc), m."""
    return _reach(pattern) + max(end_margin_m, 0.0)


def taper_m(pattern: object | None, end_margin_m: float) -> float:
    """Distance from a zone up to which a row can get the full dose (module doc), m."""
    return clearance_m(pattern, end_margin_m) + _reach(pattern)


def blocked_area(rings: Sequence[Sequence[tuple[float, float]]], grow_m: float) -> Any:
    """The union of the zones (rings, ENU m) grown by ``grow_m`` (shapely geometry), None without zones."""
    if not rings:
        return None
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    return unary_union([Polygon(r).buffer(0) for r in rings if len(r) >= 3]).buffer(grow_m)


def pass_pieces(path: Polyline, blocked: Any) -> list[Polyline]:
    """``path`` minus ``blocked`` (None: the whole path): the pieces at least :data:`MIN_PIECE_M` long, in order
    along the path and each as the path runs."""
    if blocked is None or len(path) < 2:
        return [path]
    from shapely.geometry import LineString
    from shapely.geometry import Point as P

    line = LineString(path)
    if not line.intersects(blocked):
        return [path]
    left = line.difference(blocked)
    pieces = []
    for g in getattr(left, "geoms", [left]):
        if g.is_empty or g.geom_type != "LineString" or g.length < MIN_PIECE_M:
            continue
        c = [(float(x), float(y)) for x, y in g.coords]
        a, b = line.project(P(c[0])), line.project(P(c[-1]))
        pieces.append((min(a, b), c if a <= b else c[::-1]))
    return [c for _, c in sorted(pieces, key=lambda x: x[0])]


def dosed_stretch(orig: Polyline, piece: Polyline, keep_clear: Any
                  ) -> tuple[tuple[float, float] | None, list[tuple[float, float]]]:
    """The stretch of ``piece`` (``orig`` clipped to the fence) the dose is judged on, along ``orig`` (m): (start,
    end) of its parts outside ``keep_clear`` (the zones grown by the taper; None: no zones), None when nothing is
    left; and the holes between those parts (a row passing beside a zone: the taper there is not judged)."""
    from shapely.geometry import LineString
    from shapely.geometry import Point as P

    line, part = LineString(orig), LineString(piece)
    parts = [part]
    if keep_clear is not None and part.intersects(keep_clear):
        left = part.difference(keep_clear)
        parts = [g for g in getattr(left, "geoms", [left]) if g.geom_type == "LineString" and g.length > 1e-3]
    spans = sorted((min(a, b), max(a, b)) for a, b in
                   ((line.project(P(g.coords[0])), line.project(P(g.coords[-1]))) for g in parts))
    if not spans:
        return None, []
    holes = [(a[1], b[0]) for a, b in zip(spans[:-1], spans[1:], strict=True) if b[0] > a[1]]
    return (spans[0][0], spans[-1][1]), holes
