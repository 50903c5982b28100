"""A prescription's zones as shapely polygons in an STRtree: the zone under each point, and the zones that overlap
with different rates (refused: a grower must be told); docs/dose.md §3.

Zones are rings in local metres (not closed) with holes, as :class:`~vinecli.gis.rate_map.RateMap` holds them.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vinecli.errors import InputError

__all__ = ["MAX_ZONES", "OVERLAP_TOLERANCE_M2", "ZoneIndex"]

#: the most zones a prescription may have (counted from the layer before it is read); finer maps are rasters
MAX_ZONES = 100_000
#: zones with different rates may overlap by at most this much (digitising slivers along a shared edge), m²
OVERLAP_TOLERANCE_M2 = 1.0

Ring = Sequence[tuple[float, float]]


class ZoneIndex:
    """The zones' polygons (local m) and an STRtree over them."""

    def __init__(self, rings: Sequence[Ring], holes: Sequence[Sequence[Ring]]) -> None:
        import shapely
        from shapely.geometry import Polygon

        sizes = [len(r) for r in rings]
        coords = np.concatenate([np.asarray(r, dtype=np.float64).reshape(-1, 2) for r in rings]) if rings else \
            np.empty((0, 2))
        shells = shapely.linearrings(coords, indices=np.repeat(np.arange(len(rings)), sizes))  # closed by shapely
        self.polygons = np.asarray(shapely.polygons(shells), dtype=object)
        for k in (k for k, h in enumerate(holes) if h):
            self.polygons[k] = Polygon(rings[k], holes[k])
        self.tree = shapely.STRtree(self.polygons)

    def first_zone(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The index of the first zone whose interior holds each local point (x, y, m); -1 outside every zone."""
        import shapely

        x = np.asarray(x, dtype=np.float64)
        pts = shapely.points(x.ravel(), np.asarray(y, dtype=np.float64).ravel())
        which, zone = self.tree.query(pts, predicate="within")
        first = np.full(len(pts), len(self.polygons), dtype=np.int64)
        np.minimum.at(first, which, zone)
        first[first == len(self.polygons)] = -1
        return first.reshape(x.shape)

    def check_overlaps(self, rates: Sequence[float], names: Sequence[str], path: Path,
                       tolerance_m2: float = OVERLAP_TOLERANCE_M2) -> None:
        """InputError naming the two zones (their names) that overlap the most, by more than ``tolerance_m2`` m²,
        with different ``rates`` (L/ha); zones with the same rate may overlap."""
        import shapely

        r = np.asarray(rates, dtype=np.float64)
        a, b = self.tree.query(self.polygons, predicate="intersects")
        keep = (a < b) & (r[a] != r[b])
        a, b = a[keep], b[keep]
        box = shapely.bounds(self.polygons)
        w = np.minimum(box[a, 2], box[b, 2]) - np.maximum(box[a, 0], box[b, 0])
        h = np.minimum(box[a, 3], box[b, 3]) - np.maximum(box[a, 1], box[b, 1])
        near = w * h > tolerance_m2  # the boxes' overlap bounds the polygons': neighbours that only touch drop out
        a, b = a[near], b[near]
        area = shapely.area(shapely.intersection(self.polygons[a], self.polygons[b]))
        bad = np.flatnonzero(area > tolerance_m2)
        if bad.size:
            k = bad[np.argmax(area[bad])]
            i, j = int(a[k]), int(b[k])
            more = f" ({bad.size - 1} more pair{'s' if bad.size > 2 else ''})" if bad.size > 1 else ""
            raise InputError(f"zones {names[i]!r} and {names[j]!r} overlap by {area[k]:.1f} m² with different rates "
                             f"({r[i]:g} and {r[j]:g} L/ha){more}: a prescription's zones must not overlap (cut the "
                             "inner zone out of the outer one)", path=path)
