"""Grid a point cloud into a DSM GeoTIFF (max z per cell) that ``vinecli terrain convert`` reads.

A DSM is a surface model, so each cell takes the highest point that falls in it (vine-row tops
survive). Cells without points are filled from the nearest filled cell (Euclidean distance
transform); the filled fraction is reported. Coordinates and heights are metres in the cloud's
metric CRS (see :mod:`vinecli.terrain.pointcloud.units`), written north-up with square pixels.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError, TerrainError

log = logging.getLogger(__name__)

#: Refuse grids above this many cells (float32: 1 GiB).
MAX_DSM_CELLS = 1 << 28


def grid_max_z(xyz: np.ndarray, res: float) -> tuple[np.ndarray, float, float]:
    """(z grid (rows, cols) float64 with NaN where empty, west edge x0, north edge y1).

    Cell (r, c) covers x in [x0 + c res, x0 + (c+1) res), y in (y1 - (r+1) res, y1 - r res];
    x0 and y1 are multiples of ``res`` (metres).
    """
    if not (res > 0 and math.isfinite(res)):
        raise InputError(f"--dsm resolution must be a positive number of metres, got {res}")
    x0 = math.floor(float(xyz[:, 0].min()) / res) * res
    y1 = math.ceil(float(xyz[:, 1].max()) / res) * res
    cols = int(math.floor((float(xyz[:, 0].max()) - x0) / res)) + 1
    rows = int(math.floor((y1 - float(xyz[:, 1].min())) / res)) + 1
    if rows * cols > MAX_DSM_CELLS:
        raise InputError(f"--dsm {res} m gives a {cols} x {rows} grid ({rows * cols:,} cells, limit "
                         f"{MAX_DSM_CELLS:,}); choose a coarser resolution")
    c = np.minimum(((xyz[:, 0] - x0) / res).astype(np.int64), cols - 1)
    r = np.minimum(((y1 - xyz[:, 1]) / res).astype(np.int64), rows - 1)
    z = np.full(rows * cols, -np.inf)
    np.maximum.at(z, r * cols + c, xyz[:, 2])
    z = z.reshape(rows, cols)
    z[np.isneginf(z)] = np.nan
    return z, x0, y1


def fill_nearest(z: np.ndarray) -> tuple[np.ndarray, float]:
    """Fill NaN cells with the value of the nearest non-NaN cell; return (filled grid, filled fraction)."""
    from scipy.ndimage import distance_transform_edt

    empty = np.isnan(z)
    frac = float(empty.mean())
    if not empty.any():
        return z, 0.0
    idx = distance_transform_edt(empty, return_distances=False, return_indices=True)
    return z[tuple(idx)], frac


def write_dsm(path: Path, xyz: np.ndarray, res: float, crs: Any) -> dict[str, Any]:
    """Grid ``xyz`` (metres, metric CRS coordinates) at ``res`` m and write a float32 GeoTIFF.

    Returns what was written: size, bounds, CRS name, filled fraction, z range.
    """
    import rasterio
    from rasterio.transform import from_origin

    if len(xyz) == 0:
        raise TerrainError("no points to grid into a DSM")
    z, x0, y1 = grid_max_z(xyz, res)
    z, filled = fill_nearest(z)
    rows, cols = z.shape
    profile: dict[str, Any] = {
        "driver": "GTiff", "width": cols, "height": rows, "count": 1, "dtype": "float32",
        "transform": from_origin(x0, y1, res, res), "compress": "deflate", "predictor": 3,
    }
    if cols >= 256 and rows >= 256:
        profile.update(tiled=True, blockxsize=256, blockysize=256)
    if crs is not None:
        profile["crs"] = rasterio.crs.CRS.from_wkt(crs.to_wkt())
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(z.astype(np.float32), 1)
        dst.update_tags(AREA_OR_POINT="Area", VINECLI_SOURCE="terrain reconstruct --dsm (max z per cell)")
        dst.set_band_description(1, "DSM max z (m)")
    log.info("DSM %s: %d x %d cells at %.3f m, %.1f%% filled by nearest", path, cols, rows, res, 100 * filled)
    return {
        "file": path.name, "resolution_m": res, "width": cols, "height": rows,
        "bounds": [x0, y1 - rows * res, x0 + cols * res, y1],
        "crs": None if crs is None else crs.name, "aggregation": "max", "fill": "nearest",
        "filled_fraction": filled, "z_min": float(z.min()), "z_max": float(z.max()),
    }
