"""Geofence of the built-in autopilot (PX4 geofence semantics, GF_ACTION actions).

Three independent limits, all optional (:class:`~vinecli.specs.mission.GeofenceSpec`):
an inclusion polygon (ENU x, y in m), a maximum altitude above home (m) and a maximum
horizontal distance from home (``GF_MAX_HOR_DIST``, a cylinder). The fence is breached
when any limit is violated for ``count`` consecutive checks (PX4 ``GF_COUNT``); the action
fires once per episode: a new breach needs ``rearm`` consecutive checks back inside first (a
position estimate jittering across the fence is one episode, not hundreds).

:meth:`Geofence.clearance` gives how far inside the limits a point is (preflight margins).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from vinecli.frames import Vec3
from vinecli.specs.mission import GeofenceSpec

#: PX4 GF_ACTION numbers of the action names.
GF_ACTION = {"none": 0, "warn": 1, "hold": 2, "rtl": 3, "terminate": 4, "land": 5}


def point_in_polygon(x: float, y: float, poly: Sequence[tuple[float, float]]) -> bool:
    """Even-odd ray casting; points exactly on an edge count as inside."""
    inside = False
    n = len(poly)
    j = n - 1
    for i in range(n):
        xi, yi = poly[i]
        xj, yj = poly[j]
        # on-edge test (collinear and within the segment bounds)
        cr = (xj - xi) * (y - yi) - (yj - yi) * (x - xi)
        if abs(cr) <= 1e-9 * (1.0 + abs(xj - xi) + abs(yj - yi)) and min(xi, xj) - 1e-9 <= x <= max(xi, xj) + 1e-9 \
                and min(yi, yj) - 1e-9 <= y <= max(yi, yj) + 1e-9:
            return True
        if (yi > y) != (yj > y):
            xc = xi + (y - yi) * (xj - xi) / (yj - yi)
            if x < xc:
                inside = not inside
        j = i
    return inside


def distance_to_polygon_edges(x: float, y: float, poly: Sequence[tuple[float, float]]) -> float:
    """Shortest distance (m) from (x, y) to the polygon's boundary (unsigned)."""
    from vinecli.geometry import segments

    best = math.inf
    for edge in segments([poly[-1], *poly]):  # the closing edge first
        best = min(best, float(edge.nearest(x, y)[1]))
    return best


class Geofence:
    """Checks positions against a :class:`GeofenceSpec` relative to ``home`` (ENU, m)."""

    def __init__(self, spec: GeofenceSpec, home_enu: Vec3, *, count: int = 3, rearm: int = 10) -> None:
        self.spec = spec
        self.home = home_enu
        self.action = spec.action
        self.polygon = [tuple(p) for p in spec.polygon_enu] if spec.polygon_enu else None
        self.count = max(1, count)
        self.rearm = max(1, rearm)
        self._outside = 0
        self._inside = 0
        self.breached = False

    def clearance(self, pos: Vec3) -> tuple[float, float]:
        """(horizontal, vertical) distance in m from ``pos`` (ENU) to the nearest limit: positive
        inside, negative outside, ``inf`` when the fence has no such limit."""
        s = self.spec
        horiz = math.inf
        if self.polygon is not None:
            d = distance_to_polygon_edges(pos[0], pos[1], self.polygon)  # type: ignore[arg-type]
            horiz = d if point_in_polygon(pos[0], pos[1], self.polygon) else -d  # type: ignore[arg-type]
        if s.max_horizontal_distance_m is not None:
            horiz = min(horiz, s.max_horizontal_distance_m - math.hypot(pos[0] - self.home[0], pos[1] - self.home[1]))
        vert = math.inf
        if s.max_altitude_agl_m is not None:
            vert = s.max_altitude_agl_m - (pos[2] - self.home[2])
        return horiz, vert

    def violation(self, pos: Vec3) -> str:
        """'' when inside, else which limit is violated ('polygon', 'max_altitude', 'max_distance')."""
        s = self.spec
        if s.max_altitude_agl_m is not None and pos[2] - self.home[2] > s.max_altitude_agl_m:
            return "max_altitude"
        if s.max_horizontal_distance_m is not None and \
                math.hypot(pos[0] - self.home[0], pos[1] - self.home[1]) > s.max_horizontal_distance_m:
            return "max_distance"
        if self.polygon is not None and not point_in_polygon(pos[0], pos[1], self.polygon):  # type: ignore[arg-type]
            return "polygon"
        return ""

    def check(self, pos: Vec3) -> str:
        """Update with a position; returns the violated limit on the check that triggers the
        breach (once per episode), else ''."""
        v = self.violation(pos)
        if not v:
            self._outside = 0
            self._inside += 1
            if self._inside >= self.rearm:
                self.breached = False
            return ""
        self._inside = 0
        self._outside += 1
        if self._outside >= self.count and not self.breached:
            self.breached = True
            return v
        return ""
