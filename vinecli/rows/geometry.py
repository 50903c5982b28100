"""Plane geometry of rows and tracks (ENU x, y in m)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

Polyline = Sequence[tuple[float, float]]


def point_polyline_distance(px: np.ndarray, py: np.ndarray, lines: Sequence[Polyline]) -> np.ndarray:
    """Distance (m) from each point to the nearest segment of any polyline (ENU x, y)."""
    best = np.full(px.shape, np.inf)
    for line in lines:
        pts = np.asarray(line, dtype=float)
        for (ax, ay), (bx, by) in zip(pts[:-1], pts[1:], strict=True):
            dx, dy = bx - ax, by - ay
            L2 = dx * dx + dy * dy
            u = np.clip(((px - ax) * dx + (py - ay) * dy) / L2, 0.0, 1.0) if L2 > 0 else np.zeros_like(px)
            d = np.hypot(px - (ax + u * dx), py - (ay + u * dy))
            np.minimum(best, d, out=best)
    return best


def distance_along(px: np.ndarray, py: np.ndarray, line: Polyline) -> tuple[np.ndarray, np.ndarray]:
    """(distance to ``line``, arc length of its nearest point from its first point), m, for each point."""
    pts = np.asarray(line, dtype=np.float64)
    best = np.full(px.shape, np.inf)
    s_best = np.zeros(px.shape)
    s0 = 0.0
    for (ax, ay), (bx, by) in zip(pts[:-1], pts[1:], strict=True):
        dx, dy = bx - ax, by - ay
        seg = math.hypot(dx, dy)
        if seg <= 0:
            continue
        u = np.clip(((px - ax) * dx + (py - ay) * dy) / (seg * seg), 0.0, 1.0)
        d = np.hypot(px - (ax + u * dx), py - (ay + u * dy))
        better = d < best
        best = np.where(better, d, best)
        s_best = np.where(better, s0 + u * seg, s_best)
        s0 += seg
    return best, s_best


def polyline_length(points: Polyline) -> float:
    """Length of a polyline (sum of its segment lengths), m."""
    return sum(math.dist(a, b) for a, b in zip(points[:-1], points[1:], strict=True))
