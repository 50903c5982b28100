"""The square a heightmap covers, and its vertex-aligned grid.

Conventions (docs/terrain.md §3): a heightmap of N = 2^n + 1 vertices per side spans a square
of side L from its first to its last vertex, spacing d = L / (N - 1). Vertices sit on the
square's edges. As a raster the grid has N×N cells *centred* on the vertices, i.e. its extent
is the square grown by d/2 on every side; ``rasterio.warp.reproject`` onto that grid samples
the DSM at the vertices (a decimated read would be half a pixel off).

The default region is the extent of the DSM's pixel *centres* (a DSM value is a sample at the
pixel centre), so for a 2^m+1 raster and a 2^n+1 heightmap the vertices fall on pixel centres.
``window`` (col, row, width, height, pixels) selects the centres of that block; ``bbox`` (minx,
miny, maxx, maxy, CRS units) is used as given. A region that is not square is cut to its
centred largest square.

Geographic rasters (degrees) get a local transverse Mercator grid (metres, k = 1) centred on the
region; the square is the largest centred square inside the region's (curved) outline there.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError
from vinecli.terrain.raster import DsmMeta, local_tm_crs

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SquareCrop:
    """A square in the heightmap grid's CRS.

    ``grid_crs``: rasterio CRS of the grid (the DSM's CRS, or a local TM for geographic DSMs;
    None without CRS). ``grid_to_m``: metres per grid unit. ``centre``/``side`` in grid units
    (side = first to last vertex). ``region``: the requested region in DSM CRS units.
    """

    mode: str
    grid_crs: Any
    grid_to_m: float
    centre: tuple[float, float]
    side: float
    region: tuple[float, float, float, float]
    trimmed: bool

    @property
    def side_m(self) -> float:
        """Side of the square, first to last vertex, metres."""
        return self.side * self.grid_to_m

    @property
    def vertex_bounds(self) -> tuple[float, float, float, float]:
        """(minx, miny, maxx, maxy) of the vertices, grid units."""
        cx, cy = self.centre
        h = self.side / 2
        return (cx - h, cy - h, cx + h, cy + h)

    def spacing(self, n: int) -> float:
        """Vertex spacing for an n×n grid, grid units."""
        return self.side / (n - 1)

    def vertex_transform(self, n: int, refine: int = 1) -> Any:
        """Affine of the grid whose cell centres are the vertices (refined ``refine`` times, odd).

        With ``refine`` = m > 1 the grid has n·m cells of size d/m per side, and every m-th cell
        centre (offset (m-1)/2) is a vertex, so m×m fine cells tile each vertex cell exactly.
        """
        from rasterio.transform import from_origin

        d = self.spacing(n)
        x0, _, _, y1 = self.vertex_bounds
        return from_origin(x0 - d / 2, y1 + d / 2, d / refine, d / refine)


def parse_ints(text: str, n: int, what: str, *, path: Path | None = None) -> tuple[int, ...]:
    """Parse ``"a,b,c,d"`` into n integers (InputError naming ``path`` otherwise)."""
    parts = [p for p in text.replace(" ", "").split(",") if p]
    msg = f"{what} {text!r}: expected {n} comma-separated integers"
    try:
        vals = tuple(int(p) for p in parts)
    except ValueError:
        raise InputError(msg, path=path) from None
    if len(vals) != n:
        raise InputError(msg, path=path)
    return vals


def parse_floats(text: str, n: int, what: str, *, path: Path | None = None) -> tuple[float, ...]:
    """Parse ``"a,b,c,d"`` into n floats (InputError naming ``path`` otherwise)."""
    parts = [p for p in text.replace(" ", "").split(",") if p]
    msg = f"{what} {text!r}: expected {n} comma-separated numbers"
    try:
        vals = tuple(float(p) for p in parts)
    except ValueError:
        raise InputError(msg, path=path) from None
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise InputError(msg, path=path)
    return vals


def _region(meta: DsmMeta, window: tuple[int, int, int, int] | None,
            bbox: tuple[float, float, float, float] | None) -> tuple[str, tuple[float, float, float, float]]:
    if window is not None and bbox is not None:
        raise InputError("--window and --bbox are mutually exclusive", path=meta.path)
    px, py = meta.pixel_size
    if window is not None:
        col, row, w, h = window
        if w < 2 or h < 2 or col < 0 or row < 0 or col + w > meta.width or row + h > meta.height:
            raise InputError(
                f"window col,row,width,height = {col},{row},{w},{h} lies outside the raster "
                f"({meta.width}x{meta.height} px) or is smaller than 2x2",
                path=meta.path,
            )
        t = meta.transform
        x0 = t.c + (col + 0.5) * px
        x1 = t.c + (col + w - 0.5) * px
        y1 = t.f - (row + 0.5) * py
        y0 = t.f - (row + h - 0.5) * py
        return "window", (x0, y0, x1, y1)
    if bbox is not None:
        minx, miny, maxx, maxy = bbox
        bx0, by0, bx1, by1 = meta.bounds
        eps = 1e-9 * max(abs(bx0), abs(bx1), abs(by0), abs(by1), 1.0)
        if not (minx < maxx and miny < maxy):
            raise InputError(f"bbox {bbox}: need minx < maxx and miny < maxy", path=meta.path)
        if minx < bx0 - eps or maxx > bx1 + eps or miny < by0 - eps or maxy > by1 + eps:
            raise InputError(
                f"bbox {minx:g},{miny:g},{maxx:g},{maxy:g} extends outside the raster bounds "
                f"{bx0:g},{by0:g},{bx1:g},{by1:g}",
                path=meta.path,
            )
        return "bbox", (minx, miny, maxx, maxy)
    return "centre", meta.sample_extent


def square_crop(meta: DsmMeta, *, window: tuple[int, int, int, int] | None = None,
                bbox: tuple[float, float, float, float] | None = None) -> SquareCrop:
    """The centred largest square of the chosen region (whole DSM, window or bbox)."""
    mode, region = _region(meta, window, bbox)
    x0, y0, x1, y1 = region
    if not meta.units.geographic:
        w, h = x1 - x0, y1 - y0
        side = min(w, h)
        trimmed = not math.isclose(w, h, rel_tol=1e-9)
        if trimmed:
            log.info("region %.6g x %.6g CRS units is not square: using its centred %.6g square", w, h, side)
        return SquareCrop(mode, meta.crs, meta.units.xy_to_m, ((x0 + x1) / 2, (y0 + y1) / 2), side, region, trimmed)
    # geographic: local TM at the region centre; largest centred square inside the outline
    from pyproj import Transformer

    from vinecli.terrain.raster import horizontal_crs, pyproj_crs

    lon_c, lat_c = (x0 + x1) / 2, (y0 + y1) / 2
    tm = local_tm_crs(meta.crs, lat_c, lon_c)
    tr = Transformer.from_crs(horizontal_crs(meta.crs), pyproj_crs(tm), always_xy=True)
    k = 256
    s = np.linspace(0.0, 1.0, k)
    lons = np.concatenate([x0 + s * (x1 - x0), np.full(k, x1), x1 - s * (x1 - x0), np.full(k, x0)])
    lats = np.concatenate([np.full(k, y0), y0 + s * (y1 - y0), np.full(k, y1), y1 - s * (y1 - y0)])
    ex, ny = tr.transform(lons, lats)
    half = float(np.min(np.maximum(np.abs(ex), np.abs(ny))))
    w_m = float(np.max(ex) - np.min(ex))
    h_m = float(np.max(ny) - np.min(ny))
    trimmed = not math.isclose(w_m, h_m, rel_tol=1e-6)
    return SquareCrop(mode, tm, 1.0, (0.0, 0.0), 2 * half, region, trimmed)
