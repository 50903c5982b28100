"""``terrain info``: what a DSM (or point cloud) is, and what ``convert`` would do with it.

Rasters are scanned in row strips (memory stays at one strip) for the nodata share and z range.
Point clouds are described by :func:`vinecli.terrain.pointcloud.cloud_info.cloud_info`, imported only
when a cloud is given.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError
from vinecli.terrain.defaults import TILE_PX
from vinecli.terrain.raster import CLOUD_SUFFIXES, RASTER_SUFFIXES, gdal_env, inspect_dsm, open_raster, scan_heights

log = logging.getLogger(__name__)

#: Measured PyBullet GEOM_HEIGHTFIELD memory (samples -> MB), docs/terrain.md §4.
HEIGHTFIELD_MB: tuple[tuple[int, float], ...] = ((257 * 257, 132.0), (513 * 513, 265.0), (1025 * 1025, 1000.0))
#: Measured PyBullet memory per triangle of a static concave mesh (KB), docs/terrain.md §4.
MESH_KB_PER_TRIANGLE = 0.43


def heightfield_memory_mb(samples: int) -> float:
    """Estimated PyBullet heightfield memory (MB): piecewise linear through the measured points."""
    xs = np.array([s for s, _ in HEIGHTFIELD_MB], dtype=float)
    ys = np.array([m for _, m in HEIGHTFIELD_MB], dtype=float)
    if samples >= xs[-1]:
        slope = (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
        return float(ys[-1] + slope * (samples - xs[-1]))
    if samples <= xs[0]:
        slope = (ys[1] - ys[0]) / (xs[1] - xs[0])
        return float(max(0.0, ys[0] + slope * (samples - xs[0])))
    return float(np.interp(samples, xs, ys))


def _crs_kind(crs: Any) -> tuple[str, str | None]:
    if crs is None:
        return "none", None
    from vinecli.terrain.raster import pyproj_crs

    pc = pyproj_crs(crs)
    if pc.is_compound:
        return "compound (horizontal + vertical)", pc.name
    return ("geographic" if pc.is_geographic else "projected"), pc.name


def raster_info(path: Path) -> dict[str, Any]:
    """Describe a DSM GeoTIFF and what ``terrain convert`` would do with it (JSON-able dict)."""
    from vinecli.terrain.crop import square_crop
    from vinecli.terrain.heightmap import MAX_READ_PX, MAX_SAMPLES, suggest_size
    from vinecli.terrain.raster import to_lonlat
    from vinecli.terrain.tiles import DEFAULT_MAX_ERROR, split_edges

    path = Path(path)
    with gdal_env(), open_raster(path) as src:
        meta = inspect_dsm(src)
        stats = scan_heights(src, meta)
    warnings = list(meta.warnings)
    kind, name = _crs_kind(meta.crs)
    px_m = meta.pixel_size_m()
    centre = None
    if meta.crs is not None:
        lon, lat = to_lonlat(meta.crs, *meta.centre)
        centre = {"lat": float(lat), "lon": float(lon)}
    crop = square_crop(meta)
    side_px = crop.side_m / min(px_m) + 1
    n = suggest_size(side_px)
    cell_px = crop.side_m / (n - 1) / min(px_m)
    z_min, z_max = stats["z_min"], stats["z_max"]
    relief = (z_max - z_min) if z_min is not None and z_max is not None else None
    cedges, redges = split_edges(meta.width - 1, TILE_PX), split_edges(meta.height - 1, TILE_PX)
    full_tris = 2 * (meta.width - 1) * (meta.height - 1)
    w_px = (crop.side_m / px_m[0] + 1) * (crop.side_m / px_m[1] + 1)
    if stats["valid"] == 0:
        warnings.append("every pixel is nodata: convert will refuse this raster")
    return {
        "kind": "raster",
        "file": str(path),
        "driver": meta.driver,
        "size_px": [meta.width, meta.height],
        "dtype": meta.dtype,
        "layout": (f"tiled {meta.block_shape[1]}x{meta.block_shape[0]}" if meta.tiled
                   else f"strips of {meta.block_shape[0]} row(s)") + (f", {meta.compress}" if meta.compress else ""),
        "crs": meta.crs_label if meta.crs is None or meta.crs.to_epsg() else "custom (WKT)",
        "crs_name": name,
        "crs_kind": kind,
        "units": meta.units.to_dict(),
        "pixel_size": list(meta.pixel_size),
        "pixel_size_m": list(px_m),
        "extent_m": [meta.width * px_m[0], meta.height * px_m[1]],
        "bounds": list(meta.bounds),
        "geodetic_centre": centre,
        "nodata_value": meta.nodata,
        "nodata_fraction": stats["nodata_fraction"],
        "z_min_m": z_min,
        "z_max_m": z_max,
        "relief_m": relief,
        "convert": {
            "heightmap": {
                "square_crop_m": crop.side_m,
                "square_crop_px": side_px,
                "trimmed_to_square": crop.trimmed,
                "grid": "local transverse Mercator (metres)" if meta.units.geographic else "the DSM's CRS",
                "suggested_size": n,
                "spacing_m": crop.side_m / (n - 1),
                "downsampling_factor": cell_px,
                "suggested_method": "max (keeps vine-row tops)" if cell_px >= 2 else "bilinear",
                "height_step_m": relief / 65535 if relief else 0.0,
                "pybullet_heightfield_mb": heightfield_memory_mb(n * n),
                "pybullet_ok": n * n <= MAX_SAMPLES,
                "read": "streamed (GDAL warper)" if w_px > MAX_READ_PX and cell_px >= 2 else "window at full resolution",
            },
            "tiles": {
                "tile_px": TILE_PX,
                "tile_grid": [len(redges) - 1, len(cedges) - 1],
                "full_grid_triangles": full_tris,
                "max_error_m": DEFAULT_MAX_ERROR,
                "pybullet_mb_full_grid": full_tris * MESH_KB_PER_TRIANGLE / 1024,
                "note": "pydelatin keeps 50-80% of the grid's triangles on vegetation DSMs (docs/terrain.md §1)",
            },
        },
        "warnings": warnings,
    }


def describe(path: Path) -> dict[str, Any]:
    """``terrain info``: a raster (.tif/.tiff) or a point cloud (.las/.laz/.ply/.pcd/.xyz)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in CLOUD_SUFFIXES:
        if not path.is_file():
            raise InputError("file not found", path=path)
        try:
            from vinecli.terrain.pointcloud.cloud_info import cloud_info
        except ImportError as exc:
            raise InputError(f"point-cloud info is not available in this build ({exc})", path=path) from exc
        info = dict(cloud_info(path))
        info.setdefault("kind", "pointcloud")
        info.setdefault("file", str(path))
        return info
    if suffix in RASTER_SUFFIXES:
        return raster_info(path)
    raise InputError(
        f"unknown extension {path.suffix or '(none)'!r}: expected a GeoTIFF ({'/'.join(RASTER_SUFFIXES)}) "
        f"or a point cloud ({'/'.join(CLOUD_SUFFIXES)})",
        path=path,
    )
