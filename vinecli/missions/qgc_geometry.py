"""Where a ``.plan`` puts things: world ENU (m) <-> the plan's WGS84 latitude/longitude, and the plan's geofence
(inclusion polygon, circle about home) <-> :class:`~vinecli.specs.mission.GeofenceSpec`. The one place the QGC
import and export convert coordinates (:mod:`vinecli.missions.qgc_import`, :mod:`vinecli.missions.qgc_export`).
"""

from __future__ import annotations

import math
from pathlib import Path

from vinecli.errors import SpecError
from vinecli.geo import GeoOrigin
from vinecli.missions.qgc_format import GeoFence
from vinecli.specs.mission import GeofenceSpec

__all__ = ["enu_of", "fence_from_plan", "latlon_of"]


def latlon_of(origin: GeoOrigin, x: float, y: float) -> tuple[float, float]:
    """(lat, lon) in degrees, 8 decimals (~1 mm), of the world ENU point (x, y) m."""
    lat, lon, _ = origin.enu_to_geodetic(x, y, 0.0)
    return round(lat, 8), round(lon, 8)


def enu_of(origin: GeoOrigin, lat: float, lon: float) -> tuple[float, float]:
    """World ENU (x, y) m of a plan's (lat, lon) degrees."""
    e, n, _ = origin.geodetic_to_enu(lat, lon, origin.alt)
    return e, n


def fence_from_plan(fence: GeoFence, origin: GeoOrigin, path: Path) -> GeofenceSpec | None:
    """The plan's geoFence as a GeofenceSpec in world ENU (one inclusion polygon, or a circle: about home the
    horizontal distance limit, elsewhere a 32-gon); None when it has neither; SpecError for what has no equivalent."""
    polygon: list[tuple[float, float]] | None = None
    radius: float | None = None
    for i, poly in enumerate(fence.polygons):
        if not poly.inclusion:
            raise SpecError(f"geoFence.polygons[{i}]: exclusion polygons are not supported", path=path)
        if polygon is not None:
            raise SpecError(f"geoFence.polygons[{i}]: only one inclusion polygon is supported", path=path)
        pts = []
        for lat, lon in (tuple(v[:2]) for v in poly.polygon):
            e, n = enu_of(origin, lat, lon)
            pts.append((round(e, 4), round(n, 4)))
        polygon = pts
    for i, c in enumerate(fence.circles):
        if not c.inclusion:
            raise SpecError(f"geoFence.circles[{i}]: exclusion circles are not supported", path=path)
        e, n = enu_of(origin, c.circle.center[0], c.circle.center[1])
        if math.hypot(e, n) <= 1.0:  # a cylinder about home: PX4's GF_MAX_HOR_DIST
            radius = c.circle.radius if radius is None else min(radius, c.circle.radius)
        elif polygon is None:
            polygon = [(round(e + c.circle.radius * math.cos(a), 4), round(n + c.circle.radius * math.sin(a), 4))
                       for a in (2 * math.pi * k / 32 for k in range(32))]
        else:
            raise SpecError(f"geoFence.circles[{i}]: an off-home circle and a polygon cannot be combined", path=path)
    if polygon is None and radius is None:
        return None
    return GeofenceSpec(polygon_enu=polygon, max_horizontal_distance_m=radius)
