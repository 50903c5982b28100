"""Plane geometry in the world's x, y (ENU m): segments of polylines and polygons, the projection of points onto
them, distances to them, points in polygons. Works on numpy arrays of points and on single floats alike.

THE projection of a point P onto the segment from A along D = B - A (:class:`Segment`): the fraction
``u = ((P - A) · D) / |D|²`` (0 at A, 1 at B), clamped to [0, 1] for the nearest point ``A + u D``, and the
distance ``|P - (A + u D)|`` (``np.hypot`` for arrays, ``math.hypot`` for single floats). Callers whose outputs
are recorded bit for bit round ``|D|²`` one of two ways, chosen once per polyline in :func:`segments`:
``"sum"`` = ``dx * dx + dy * dy``, ``"hypot"`` = ``length * length`` with ``length = math.hypot(dx, dy)`` (the
callers that measure arc lengths as ``start + u * length``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, TypeVar

import numpy as np

__all__ = ["Polyline", "Segment", "convex_signed_distance", "distance_along", "point_polyline_distance",
           "points_in_polygon", "polyline_length", "segments"]

#: a polyline or polygon ring, (x, y) vertices in m
Polyline = Sequence[tuple[float, float]]
#: points: numpy arrays (one value per point) or single floats
Points = TypeVar("Points", np.ndarray, float)


@dataclass(frozen=True, slots=True)
class Segment:
    """The segment from (``ax``, ``ay``) to (``bx``, ``by``) along (``dx``, ``dy``) = B - A, m; ``length`` =
    ``math.hypot(dx, dy)``, ``len2`` its squared length as the caller rounds it (module doc), ``start`` the
    length of its polyline before it, m."""

    ax: float
    ay: float
    bx: float
    by: float
    dx: float
    dy: float
    length: float
    len2: float
    start: float

    def fraction(self, px: Points, py: Points) -> Points:
        """Where the foot of the perpendicular from each point falls: 0 at the start, 1 at the end, not clamped
        (0 for a segment of zero length)."""
        if not self.len2 > 0:
            return np.zeros_like(px) if isinstance(px, np.ndarray) else 0.0  # type: ignore[return-value]
        return ((px - self.ax) * self.dx + (py - self.ay) * self.dy) / self.len2  # type: ignore[no-any-return]

    @staticmethod
    def clamp(u: Points) -> Points:
        """A fraction clamped to the segment, [0, 1]."""
        if isinstance(u, np.ndarray):
            return np.clip(u, 0.0, 1.0)
        return min(max(u, 0.0), 1.0)

    def distance(self, px: Points, py: Points, u: Points) -> Points:
        """Distance (m) from each point to the segment's point at the clamped fraction ``u``."""
        ex, ey = px - (self.ax + u * self.dx), py - (self.ay + u * self.dy)
        if isinstance(ex, np.ndarray):
            return np.hypot(ex, ey)  # type: ignore[no-any-return]
        return math.hypot(ex, ey)  # type: ignore[return-value]

    def nearest(self, px: Points, py: Points) -> tuple[Points, Points]:
        """(clamped fraction of the nearest point of the segment, distance to it m) of each point."""
        u = self.clamp(self.fraction(px, py))
        return u, self.distance(px, py, u)


def segments(line: Polyline | np.ndarray, len2: Literal["sum", "hypot"] = "sum") -> list[Segment]:
    """The segments of a polyline in order (a polygon ring: close it, last vertex = first); ``len2``: how their
    squared length is rounded (module doc)."""
    pts = np.asarray(line, dtype=np.float64)
    out: list[Segment] = []
    start = 0.0
    for (ax, ay), (bx, by) in zip(pts[:-1], pts[1:], strict=True):
        dx, dy = bx - ax, by - ay
        length = math.hypot(dx, dy)
        squared = dx * dx + dy * dy if len2 == "sum" else length * length
        out.append(Segment(ax, ay, bx, by, dx, dy, length, squared, start))
        start += length
    return out


def point_polyline_distance(px: np.ndarray, py: np.ndarray, lines: Sequence[Polyline]) -> np.ndarray:
    """Distance (m) from each point to the nearest segment of any polyline."""
    best = np.full(px.shape, np.inf)
    for line in lines:
        for seg in segments(line):
            np.minimum(best, seg.nearest(px, py)[1], out=best)
    return best


def distance_along(px: np.ndarray, py: np.ndarray, line: Polyline) -> tuple[np.ndarray, np.ndarray]:
    """(distance to the polyline ``line``, arc length of its nearest point from its first vertex), m, of each
    point (segments of zero length skipped; the first of equally near segments wins)."""
    best = np.full(px.shape, np.inf)
    s_best = np.zeros(px.shape)
    for seg in segments(line, len2="hypot"):
        if seg.length <= 0:
            continue
        u, d = seg.nearest(px, py)
        better = d < best
        best = np.where(better, d, best)
        s_best = np.where(better, seg.start + u * seg.length, s_best)
    return best, s_best


def polyline_length(points: Polyline) -> float:
    """Length of a polyline (sum of its segment lengths), m."""
    return sum(math.dist(a, b) for a, b in zip(points[:-1], points[1:], strict=True))


def convex_signed_distance(ring: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Distance (m) from each point to the boundary of the convex polygon ``ring`` ((n, 2) vertices, closed),
    negative inside."""
    best = np.full(x.shape, np.inf)
    inside = np.ones(x.shape, dtype=bool)
    area2 = float(np.sum(ring[:-1, 0] * ring[1:, 1] - ring[1:, 0] * ring[:-1, 1]))  # > 0: counter-clockwise
    for edge in segments(ring):
        if not edge.len2 > 0:
            continue
        rx, ry = x - edge.ax, y - edge.ay  # the points from the edge's start: the edge measured from (0, 0)
        from_start = Segment(0.0, 0.0, edge.dx, edge.dy, edge.dx, edge.dy, edge.length, edge.len2, 0.0)
        best = np.minimum(best, from_start.nearest(rx, ry)[1])
        inside &= (edge.dx * ry - edge.dy * rx) * area2 >= 0.0
    return np.where(inside, -best, best)


def points_in_polygon(x: np.ndarray, y: np.ndarray, poly: Polyline) -> np.ndarray:
    """Even-odd ray casting, vectorised over the points (ENU m); boolean mask."""
    inside = np.zeros(np.shape(x), dtype=bool)
    pts = np.asarray(poly, dtype=np.float64)
    n = len(pts)
    for i in range(n):
        x1, y1 = pts[i]
        x2, y2 = pts[(i + 1) % n]
        if y1 == y2:
            continue
        cond = (y1 > y) != (y2 > y)
        xint = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
        inside ^= cond & (x < xint)
    return inside
