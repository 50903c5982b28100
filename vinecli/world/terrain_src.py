"""Terrain inputs of ``world build`` -> a height grid in the world's ENU frame.

The terrain itself comes from the terrain tools (:mod:`vinecli.terrain.heightmap`,
:mod:`vinecli.terrain.tiles`): a heightmap directory (N×N heights, row 0 north, centred on its
geodetic origin) or a tiles directory (OBJ/STL meshes in local metres about the origin in
tiles.json). This module turns either into a :class:`~vinecli.terrain.grid.TerrainGrid` for fast
``terrain_height`` lookups, and works out the offset of the terrain's own origin in the world's
ENU frame when the world file gives a different geodetic origin (local tangent plane).

For tiles the grid is ray-cast through PyBullet against the very meshes the vehicle collides
with (every 5 cm by default), so lookups agree with the collision surface.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np

from vinecli.errors import TerrainError
from vinecli.frames import Vec3
from vinecli.geo import GeoOrigin
from vinecli.terrain.grid import TerrainGrid

__all__ = ["heightmap_grid", "origin_offset", "tiles_grid"]

log = logging.getLogger(__name__)


def origin_offset(terrain_origin: GeoOrigin | None, world_origin: GeoOrigin) -> Vec3:
    """ENU position (m) of the terrain's origin in the world frame (0 when they coincide or unknown)."""
    if terrain_origin is None:
        return (0.0, 0.0, 0.0)
    if (abs(terrain_origin.lat - world_origin.lat) < 1e-10 and abs(terrain_origin.lon - world_origin.lon) < 1e-10
            and abs(terrain_origin.alt - world_origin.alt) < 1e-6):
        return (0.0, 0.0, 0.0)
    return world_origin.geodetic_to_enu(terrain_origin.lat, terrain_origin.lon, terrain_origin.alt)


def heightmap_grid(heights_north_up: np.ndarray, spacing_m: float, centre_enu: tuple[float, float],
                   z_offset: float) -> TerrainGrid:
    """Grid of a square heightmap (row 0 = north) centred at ``centre_enu``; z = height + z_offset."""
    n = heights_north_up.shape[0]
    c = (n - 1) / 2.0
    z = heights_north_up[::-1, :].astype(np.float64) + z_offset
    return TerrainGrid(z, centre_enu[0] - c * spacing_m, centre_enu[1] - c * spacing_m, spacing_m, spacing_m)


def tiles_grid(files: list[Path], offset: Vec3, spacing_m: float = 0.05) -> TerrainGrid:
    """Height grid (ENU) ray-cast on mesh tiles placed at ``offset`` (m)."""
    from vinecli.world.engine import Engine
    from vinecli.world.model import TerrainInfo

    if not files:
        raise TerrainError("no mesh tiles")
    with Engine() as eng:
        bodies = eng.load_terrain(TerrainInfo("tiles", files=files, offset=offset))
        lo = [math.inf] * 3
        hi = [-math.inf] * 3
        for b in bodies:
            a, c = eng.client.getAABB(b)
            lo = [min(lo[k], a[k]) for k in range(3)]
            hi = [max(hi[k], c[k]) for k in range(3)]
        # AABBs carry a small collision margin: stay inside by 2 mm
        x0, x1, y0, y1 = lo[0] + 0.002, hi[0] - 0.002, lo[1] + 0.002, hi[1] - 0.002
        nx = max(2, int(round((x1 - x0) / spacing_m)) + 1)
        ny = max(2, int(round((y1 - y0) / spacing_m)) + 1)
        xs = np.linspace(x0, x1, nx)
        ys = np.linspace(y0, y1, ny)
        z = np.full((ny, nx), np.nan)
        top, bottom = hi[2] + 1.0, lo[2] - 1.0
        batch = max(1, 8192 // nx)
        for j0 in range(0, ny, batch):
            rows = ys[j0 : j0 + batch]
            starts = [[x, y, top] for y in rows for x in xs]
            ends = [[x, y, bottom] for y in rows for x in xs]
            hits = eng.client.rayTestBatch(starts, ends)
            z[j0 : j0 + len(rows)] = np.array([h[3][2] if h[0] >= 0 else np.nan for h in hits]).reshape(len(rows), nx)
    missing = ~np.isfinite(z)
    if missing.all():
        raise TerrainError("no ray hit the terrain tiles")
    if missing.any():
        from scipy import ndimage

        log.warning("%.2f %% of the terrain grid has no tile below it (holes); filled by nearest",
                    100.0 * missing.mean())
        idx = ndimage.distance_transform_edt(missing, return_distances=False, return_indices=True)
        z = z[tuple(idx)]
    return TerrainGrid(z, float(xs[0]), float(ys[0]), float(xs[1] - xs[0]), float(ys[1] - ys[0]))
