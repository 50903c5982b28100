"""The canopy segments of a DSM GeoTIFF: rows detected on it (:func:`vinecli.rows.source.detect_rows_in_dsm`),
then measured at the raster's own resolution (:func:`vinecli.rows.canopy_segments.segment_canopy`), in the
DSM's local frame (metres along the CRS axes about the raster centre, :class:`~vinecli.rows.source.RowFrame`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vinecli.errors import TerrainError
from vinecli.rows.canopy_segments import CanopySegments, Sampling, segment_canopy
from vinecli.rows.source import DsmRows, detect_rows_in_dsm

__all__ = ["DsmCanopy", "RasterHeights", "measure_dsm_canopy"]

#: cells read at most (a larger DSM is read averaged down to about this many)
MAX_CELLS = 6_000_000


@dataclass(frozen=True)
class RasterHeights:
    """A north-up height grid in a local frame: ``z[iy, ix]`` at x = x0 + ix dx, y = y0 + iy dy (row 0 south),
    NaN = no data; :meth:`__call__` is bilinear (NaN next to missing data and outside)."""

    z: np.ndarray
    x0: float
    y0: float
    dx: float
    dy: float

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        from scipy.ndimage import map_coordinates

        fx = (np.asarray(x, dtype=np.float64) - self.x0) / self.dx
        fy = (np.asarray(y, dtype=np.float64) - self.y0) / self.dy
        return np.asarray(map_coordinates(self.z, [fy, fx], order=1, mode="constant", cval=np.nan, prefilter=False))


@dataclass(frozen=True)
class DsmCanopy:
    """Rows detected on a DSM and their measured segments (both in the DSM's local frame)."""

    rows: DsmRows
    segments: CanopySegments
    heights: RasterHeights


def read_heights(path: Path, rows: DsmRows, max_cells: int = MAX_CELLS) -> RasterHeights:
    """The DSM's heights in ``rows.frame`` (its local metres), at full resolution up to ``max_cells`` cells."""
    import rasterio

    try:
        with rasterio.open(path) as ds:
            f = max(1, math.ceil(math.sqrt(ds.width * ds.height / max_cells)))
            shape = (max(2, ds.height // f), max(2, ds.width // f))
            z = ds.read(1, out_shape=shape, masked=True, resampling=rasterio.enums.Resampling.average)
            z = np.ma.filled(z.astype(np.float64), np.nan)
            tr = ds.transform @ ds.transform.scale(ds.width / shape[1], ds.height / shape[0])
    except rasterio.errors.RasterioError as exc:
        raise TerrainError(f"cannot read raster: {exc}", path=path) from None
    z[~np.isfinite(z) | (np.abs(z) > 1e6)] = np.nan
    (cx, cy), (sx, sy) = rows.frame.centre, rows.frame.scale
    dx, dy = tr.a * sx, tr.e * sy
    x0 = (tr.c + 0.5 * tr.a - cx) * sx
    y0 = (tr.f + 0.5 * tr.e - cy) * sy
    if dy < 0:  # north-up raster: row 0 is north; flip so that row 0 is south
        z, y0, dy = z[::-1], y0 + (z.shape[0] - 1) * dy, -dy
    return RasterHeights(np.ascontiguousarray(z), float(x0), float(y0), float(dx), float(dy))


def measure_dsm_canopy(path: Path | str, *, base_m: float = 0.0, segment_m: float = 2.0,
                       spacing_m: float | None = None, gap_min_m: float = 0.5) -> DsmCanopy:
    """Detect the rows of the DSM at ``path`` and measure their canopy segment by segment (``base_m``: the
    foliage base above the ground, m; ``spacing_m``: the expected row spacing, default searched)."""
    path = Path(path)
    rows = detect_rows_in_dsm(path, spacing_m=spacing_m)
    heights = read_heights(path, rows)
    step = min(0.1, max(abs(heights.dx), 0.02))
    segs = segment_canopy(heights, rows.detection.rows, spacing_m=rows.detection.spacing_m, base_m=base_m,
                          segment_m=segment_m, sampling=Sampling(
                              step_m=step, across_step_m=min(rows.detection.spacing_m / 32.0, max(abs(heights.dx), 0.01)),
                              gap_min_m=gap_min_m))
    return DsmCanopy(rows, segs, heights)
