"""``terrain convert --to heightmap``: DSM -> square N×N heightmap (N = 2^n + 1).

Pipeline: validate the DSM (:mod:`~vinecli.terrain.raster`) -> square crop
(:mod:`~vinecli.terrain.crop`) -> read the crop with a margin, nodata masked in the native dtype
-> fill holes (:mod:`~vinecli.terrain.fill`) -> ``rasterio.warp.reproject`` onto the grid whose
cell centres are the heightmap vertices -> write ``heightmap.png`` (16-bit), ``heightmap.tif``
(float32 metres, georeferenced, same grid) and ``heightmap.json``.

Large inputs (crop above :data:`MAX_READ_PX` pixels, output much coarser than the pixels) are
never read whole at full resolution: GDAL's warper streams the file into an intermediate grid
``refine`` (odd) times finer than the heightmap (aggregating with ``max`` for ``max`` and
``average`` otherwise, nodata-aware), holes left there are filled, and that grid is resampled to
the vertices with the chosen method. Peak memory then stays near the intermediate grid.

Heights are metres in the DSM's vertical datum. The local frame (for worlds): x east, y north,
z up; vertex (row i, col j) is at x = (j - c)·d, y = (c - i)·d with c = (N-1)/2, row 0 = north.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError, RuntimeFailure, TerrainError
from vinecli.geo import GeoOrigin
from vinecli.outputs import Manifest, atomic_output_dir, write_json
from vinecli.terrain.crop import SquareCrop, square_crop
from vinecli.terrain.defaults import FILL, HEIGHTMAP_METHOD
from vinecli.terrain.fill import FillResult, fill_nodata, parse_fill
from vinecli.terrain.raster import (
    DsmMeta,
    check_out_dir,
    crs_label,
    gdal_env,
    horizontal_crs,
    inspect_dsm,
    open_raster,
    placeholder_crs,
    read_format_json,
    read_heights,
    to_lonlat,
)

log = logging.getLogger(__name__)

METHODS: tuple[str, ...] = ("bilinear", "cubic", "average", "max", "nearest")
#: PyBullet GEOM_HEIGHTFIELD breaks silently above this many samples (docs/terrain.md §4).
MAX_SAMPLES = 2**21
#: Crops above this many pixels are streamed through GDAL's warper when downsampling.
MAX_READ_PX = 2**25
#: Pixel budget of the intermediate grid of the streamed path.
MAX_INTERMEDIATE_PX = 2**22
#: Samples used to measure what the resolution loses (strided above this).
LOSS_SAMPLES = 1_000_000
FORMAT = "vinecli-heightmap/1"


@dataclass
class Heightmap:
    """A square heightmap: N×N heights (float32 metres, row 0 = north edge, col 0 = west edge).

    ``spacing_m``: vertex spacing. ``origin``: geodetic origin (lat/lon of the centre vertex, alt
    = height at the centre vertex) or None when the DSM has no CRS. ``meta``: heightmap.json.
    ``grid_crs``/``transform``: rasterio CRS and affine of heightmap.tif (cells centred on vertices).
    """

    heights: np.ndarray
    spacing_m: float
    origin: GeoOrigin | None
    meta: dict[str, Any] = field(default_factory=dict)
    dir: Path | None = None
    grid_crs: Any = None
    transform: Any = None

    @property
    def size(self) -> int:
        """N, vertices per side."""
        return int(self.heights.shape[0])

    @property
    def size_m(self) -> float:
        """Side of the square, first to last vertex, metres."""
        return (self.size - 1) * self.spacing_m

    @property
    def z_min(self) -> float:
        """Lowest height, metres."""
        return float(self.heights.min())

    @property
    def z_max(self) -> float:
        """Highest height, metres."""
        return float(self.heights.max())

    @property
    def centre_height(self) -> float:
        """Height at the centre vertex, metres (the origin altitude)."""
        c = (self.size - 1) // 2
        return float(self.heights[c, c])

    def enu_axes(self) -> tuple[np.ndarray, np.ndarray]:
        """(x east of each column, y north of each row), metres, relative to the centre vertex."""
        c = (self.size - 1) / 2
        j = np.arange(self.size, dtype=np.float64)
        return (j - c) * self.spacing_m, (c - j) * self.spacing_m

    def heights_enu(self) -> np.ndarray:
        """Heights relative to the origin altitude (ENU z, metres), float64."""
        return self.heights.astype(np.float64) - self.centre_height


@dataclass(frozen=True)
class GridResult:
    """Resampled heights plus how they were obtained."""

    heights: np.ndarray
    fill: FillResult
    read_mode: str
    source_window: tuple[int, int, int, int] | None
    loss: dict[str, Any] | None
    nodata_fraction: float


def validate_size(n: int, *, path: Path | None = None) -> None:
    """InputError unless ``n`` = 2^k + 1 (k >= 1) and n² <= 2^21 (PyBullet heightfield limit)."""
    if n < 3 or (n - 1) & (n - 2) != 0:
        raise InputError(f"--size {n} is not 2^n+1 (use 129, 257, 513 or 1025)", path=path)
    if n * n > MAX_SAMPLES:
        raise InputError(
            f"--size {n}: {n * n:,} samples exceed 2^21 = {MAX_SAMPLES:,}; PyBullet heightfields break silently "
            "above that (garbage bounding box, rays miss); use --size 1025 or less, or mesh tiles (--to tiles)",
            path=path,
        )


def suggest_size(side_px: float) -> int:
    """Smallest 2^n+1 >= the crop's pixel count per side, capped at 1025 (PyBullet limit)."""
    n = 3
    while n < side_px - 1e-9 and n < 1025:
        n = 2 * n - 1
    return n


def _resampling(method: str, path: Path | None = None) -> Any:
    from rasterio.enums import Resampling

    if method not in METHODS:
        raise InputError(f"--method {method!r}: choose one of {', '.join(METHODS)}", path=path)
    return Resampling[method]


def _crss(meta: DsmMeta, crop: SquareCrop) -> tuple[Any, Any]:
    if meta.crs is None:
        ph = placeholder_crs()
        return ph, ph
    return meta.crs, crop.grid_crs


def _source_window(meta: DsmMeta, crop: SquareCrop, n: int, margin_px: int) -> Any:
    """Pixel window of the DSM covering the heightmap cells plus ``margin_px``."""
    from rasterio.warp import transform_bounds
    from rasterio.windows import Window, from_bounds

    d = crop.spacing(n)
    x0, y0, x1, y1 = crop.vertex_bounds
    b = (x0 - d / 2, y0 - d / 2, x1 + d / 2, y1 + d / 2)
    if meta.units.geographic:
        b = transform_bounds(crop.grid_crs, meta.crs, *b, densify_pts=64)
    w = from_bounds(*b, transform=meta.transform)
    c0 = max(0, math.floor(w.col_off) - margin_px)
    r0 = max(0, math.floor(w.row_off) - margin_px)
    c1 = min(meta.width, math.ceil(w.col_off + w.width) + margin_px)
    r1 = min(meta.height, math.ceil(w.row_off + w.height) + margin_px)
    if c1 <= c0 or r1 <= r0:
        raise TerrainError("crop does not overlap the raster", path=meta.path)
    return Window(c0, r0, c1 - c0, r1 - r0)


def _cell_px(meta: DsmMeta, crop: SquareCrop, n: int) -> float:
    """Heightmap spacing in DSM pixels (coarser = larger)."""
    d_m = crop.spacing(n) * crop.grid_to_m
    return d_m / min(meta.pixel_size_m())


def _reproject(src_arr: Any, dst: np.ndarray, *, src_transform: Any, src_crs: Any, dst_transform: Any, dst_crs: Any,
               method: str, src_nodata: float | None = None) -> None:
    from rasterio.warp import reproject

    reproject(
        source=src_arr, destination=dst, src_transform=src_transform, src_crs=src_crs,
        src_nodata=np.nan if src_nodata is None else src_nodata, dst_transform=dst_transform, dst_crs=dst_crs,
        dst_nodata=np.nan, resampling=_resampling(method), num_threads=1, warp_mem_limit=64, init_dest_nodata=True,
    )


def _loss(meta: DsmMeta, crop: SquareCrop, n: int, heights: np.ndarray, z: np.ndarray, valid: np.ndarray,
          win: Any) -> dict[str, Any]:
    """What the chosen resolution loses: DSM samples in the square vs the heightmap (bilinear) there."""
    from scipy.ndimage import map_coordinates

    stride = max(1, math.ceil(math.sqrt(valid.size / LOSS_SAMPLES)))  # regular subgrid, bounded memory
    r_sub = np.arange(0, valid.shape[0], stride)
    c_sub = np.arange(0, valid.shape[1], stride)
    rr, cc = np.nonzero(valid[np.ix_(r_sub, c_sub)])
    rows, cols = r_sub[rr], c_sub[cc]
    del rr, cc
    t = meta.transform
    xs = t.c + (win.col_off + cols + 0.5) * t.a
    ys = t.f + (win.row_off + rows + 0.5) * t.e
    if meta.units.geographic:
        from pyproj import Transformer

        from vinecli.terrain.raster import pyproj_crs

        tr = Transformer.from_crs(horizontal_crs(meta.crs), pyproj_crs(crop.grid_crs), always_xy=True)
        xs, ys = tr.transform(xs, ys)
    x0, _, _, y1 = crop.vertex_bounds
    d = crop.spacing(n)
    fc = (np.asarray(xs) - x0) / d
    fr = (y1 - np.asarray(ys)) / d
    inside = (fc >= 0) & (fc <= n - 1) & (fr >= 0) & (fr <= n - 1)
    if not inside.any():
        return {"samples": 0}
    hm = map_coordinates(heights.astype(np.float64), [fr[inside], fc[inside]], order=1, mode="nearest")
    src = z[rows[inside], cols[inside]].astype(np.float64)
    diff = hm - src
    return {
        "samples": int(diff.size),
        "rms_m": float(np.sqrt(np.mean(diff**2))),
        "max_abs_m": float(np.max(np.abs(diff))),
        "p99_abs_m": float(np.percentile(np.abs(diff), 99)),
        "max_below_source_m": float(max(0.0, -np.min(diff))),
        "note": "DSM samples inside the square vs the heightmap interpolated bilinearly at their positions",
    }


def resample(meta: DsmMeta, src: Any, crop: SquareCrop, n: int, method: str = HEIGHTMAP_METHOD,
             fill: str | float = FILL, *, max_read_px: int = MAX_READ_PX) -> GridResult:
    """Heights (float32 metres) at the n×n vertices of ``crop``; nodata filled before resampling."""
    import rasterio

    _resampling(method)
    cell_px = _cell_px(meta, crop, n)
    src_crs, dst_crs = _crss(meta, crop)
    dst_transform = crop.vertex_transform(n)
    win = _source_window(meta, crop, n, margin_px=math.ceil(2 * cell_px) + 3)
    heights = np.full((n, n), np.nan, dtype=np.float32)
    if win.width * win.height <= max_read_px or cell_px < 2.0:
        z, valid = read_heights(src, meta, win)
        inner = _source_window(meta, crop, n, margin_px=0)
        r0, c0 = inner.row_off - win.row_off, inner.col_off - win.col_off
        core = valid[r0:r0 + inner.height, c0:c0 + inner.width]
        nodata_fraction = 1.0 - float(core.mean()) if core.size else 0.0
        if not core.any():
            raise TerrainError("no valid heights in the crop: every pixel is nodata", path=meta.path)
        filled = z.copy() if not valid.all() else z
        fres = fill_nodata(filled, fill, path=meta.path)
        _reproject(filled, heights, src_transform=src.window_transform(win), src_crs=src_crs,
                   dst_transform=dst_transform, dst_crs=dst_crs, method=method)
        if filled is not z:
            del filled
        loss = _loss(meta, crop, n, heights, z, valid, win)
        mode = "full resolution (window read)"
        window = (int(win.col_off), int(win.row_off), int(win.width), int(win.height))
    else:
        refine = 1
        side_cap = math.isqrt(MAX_INTERMEDIATE_PX) // n
        while refine + 2 <= min(cell_px, side_cap):
            refine += 2
        m = n * refine
        inter = np.full((m, m), np.nan, dtype=np.float32)
        agg = method if refine == 1 else "max" if method == "max" else "nearest" if method == "nearest" else "average"
        from rasterio.errors import RasterioError

        try:
            _reproject(rasterio.band(src, 1), inter, src_transform=meta.transform, src_crs=src_crs,
                       dst_transform=crop.vertex_transform(n, refine), dst_crs=dst_crs, method=agg,
                       src_nodata=meta.nodata)
        except RasterioError as exc:
            raise TerrainError(f"cannot read pixel data, truncated or corrupt? ({exc})", path=meta.path) from exc
        inter = meta.scaled(inter)
        h = (refine - 1) // 2  # fine cells outside the vertex square on each side
        core = inter[h:m - h, h:m - h]
        nodata_fraction = float(np.isnan(core).mean())
        if nodata_fraction == 1.0:
            raise TerrainError("no valid heights in the crop: every pixel is nodata", path=meta.path)
        fres = fill_nodata(inter, fill, path=meta.path)
        fres = FillResult(f"{fres.method} (on the {m}x{m} streamed grid)", nodata_fraction,
                          int(round(nodata_fraction * core.size)))
        if refine == 1:
            heights[...] = inter
        elif method in ("max", "average"):  # exact: the m×m fine cells tile each vertex cell
            blocks = inter.reshape(n, refine, n, refine)
            heights[...] = blocks.max(axis=(1, 3)) if method == "max" else blocks.mean(axis=(1, 3), dtype=np.float64)
        elif method == "nearest":
            heights[...] = inter[h::refine, h::refine]
        else:
            _reproject(inter, heights, src_transform=crop.vertex_transform(n, refine), src_crs=dst_crs,
                       dst_transform=dst_transform, dst_crs=dst_crs, method=method)
        del inter
        loss = None
        mode = (f"streamed: GDAL warper {agg} onto a grid {refine}x finer than the heightmap ({m}x{m}), "
                f"then {method}" if refine > 1 else f"streamed: GDAL warper {method} onto the vertex grid")
        window = None
    if np.isnan(heights).any():
        raise RuntimeFailure("resampled heightmap has cells without data (crop outside the raster?)", path=meta.path)
    return GridResult(heights, fres, mode, window, loss, nodata_fraction)


def png16(heights: np.ndarray) -> tuple[np.ndarray, float, float, float]:
    """Quantise heights to uint16: 0..65535 <-> z_min..z_max. Returns (q, z_min, z_max, step_m)."""
    z_min, z_max = float(heights.min()), float(heights.max())
    step = (z_max - z_min) / 65535.0
    if step == 0:
        return np.zeros(heights.shape, np.uint16), z_min, z_max, 0.0
    q = np.rint((heights.astype(np.float64) - z_min) / step)
    return np.clip(q, 0, 65535).astype(np.uint16), z_min, z_max, step


def build_heightmap(dsm: Path, size: int | None = None, *, method: str = HEIGHTMAP_METHOD,
                    window: tuple[int, int, int, int] | None = None,
                    bbox: tuple[float, float, float, float] | None = None, fill: str | float = FILL,
                    z_unit: str | None = None, max_read_px: int = MAX_READ_PX) -> Heightmap:
    """Make a heightmap in memory (no files). ``size`` None -> :func:`suggest_size` of the crop.

    Parameters are those of :func:`convert_to_heightmap`; ``Heightmap.meta`` holds the sidecar.
    """
    t0 = time.perf_counter()
    dsm = Path(dsm)
    fill = parse_fill(fill, path=dsm)
    _resampling(method, dsm)
    if size is not None:
        validate_size(size, path=dsm)
    with gdal_env(), open_raster(dsm) as src:
        meta = inspect_dsm(src, z_unit=z_unit)
        crop = square_crop(meta, window=window, bbox=bbox)
        side_px = crop.side_m / min(meta.pixel_size_m()) + 1
        if size is None:
            size = suggest_size(side_px)
            log.info("heightmap size %d (crop is %.0f px per side)", size, side_px)
        if crop.side_m <= 0:
            raise TerrainError("crop has zero size", path=dsm)
        cell_px = _cell_px(meta, crop, size)
        if cell_px >= 2 and method not in ("max", "average"):
            log.warning("downsampling %.1fx with %s: features narrower than %.1f px (vine rows) may be lost; "
                        "--method max keeps row tops", cell_px, method, cell_px)
        grid = resample(meta, src, crop, size, method, fill, max_read_px=max_read_px)
    heights = grid.heights
    n = size
    c = (n - 1) // 2
    alt = float(heights[c, c])
    cx, cy = crop.centre
    warnings = list(meta.warnings)
    origin: GeoOrigin | None = None
    if crop.grid_crs is not None:
        lon, lat = to_lonlat(crop.grid_crs, cx, cy)
        origin = GeoOrigin(float(lat), float(lon), alt)
    if meta.units.geographic:
        from vinecli.terrain.raster import metres_per_degree

        m_lat, m_lon = metres_per_degree(origin.lat if origin else 0.0)
        rx0, ry0, rx1, ry1 = crop.region  # the local TM grid is centred on the region's centre
        src_origin = [(rx0 + rx1) / 2, (ry0 + ry1) / 2]
        warnings.append(f"geographic CRS: resampled onto a local transverse Mercator grid centred at the origin "
                        f"(metres per degree there: {m_lon:.1f} E-W, {m_lat:.1f} N-S)")
    else:
        src_origin = [cx, cy]
    _, z_min, z_max, step = png16(heights)
    d = crop.spacing(n)
    x0, y0, x1, y1 = crop.vertex_bounds
    sidecar: dict[str, Any] = {
        "format": FORMAT,
        "size_px": n,
        "size_m": [crop.side_m, crop.side_m],
        "spacing_m": d * crop.grid_to_m,
        "z_min": z_min,
        "z_max": z_max,
        "height_step_m": step,
        "png_encoding": "uint16 value v <-> height z_min + v * height_step_m (metres)",
        "crs": meta.crs_label,
        "grid_crs": crs_label(crop.grid_crs),
        "origin": src_origin,
        "origin_grid_crs": [cx, cy],
        "origin_note": "centre vertex of the square: 'origin' in crs units (lon/lat for a geographic DSM), "
                       "'origin_grid_crs' in grid_crs units (the heightmap.tif grid)",
        "origin_alt_m": alt,
        "geodetic_origin": origin.to_dict() if origin else None,
        "geodetic_origin_note": ("lat/lon (WGS84) of the centre vertex; alt = height there (DSM vertical datum, m)"
                                 if origin else "unknown: the DSM has no CRS"),
        "bounds": [x0, y0, x1, y1],
        "bounds_note": "first/last vertices (grid_crs units); the GeoTIFF's cells are centred on the vertices",
        "layout": "row 0 = north edge, column 0 = west edge; ENU x = (col - (N-1)/2) * spacing_m, "
                  "y = ((N-1)/2 - row) * spacing_m, z = height - origin_alt_m (the height at the centre vertex)",
        "resampling": method,
        "read": grid.read_mode,
        "crop": {"mode": crop.mode, "region_source_crs": list(crop.region), "trimmed_to_square": crop.trimmed,
                 "window_px": list(window) if window else None, "bbox": list(bbox) if bbox else None},
        "nodata_fraction": grid.nodata_fraction,
        "nodata_filled_fraction": grid.fill.filled_fraction,
        "fill_method": grid.fill.method,
        "resolution_loss": grid.loss,
        "units": meta.units.to_dict(),
        "source": {"file": str(dsm), "name": dsm.name, "size_px": [meta.width, meta.height], "dtype": meta.dtype,
                   "nodata": meta.nodata, "pixel_size": list(meta.pixel_size),
                   "pixel_size_m": list(meta.pixel_size_m()), "window_read": grid.source_window},
        "pybullet_heightfield": {"samples": n * n, "max_samples": MAX_SAMPLES, "ok": n * n <= MAX_SAMPLES},
        "warnings": warnings,
        "seconds": round(time.perf_counter() - t0, 3),
    }
    return Heightmap(heights, d * crop.grid_to_m, origin, sidecar, None, _tif_crs(meta, crop), crop.vertex_transform(n))


def write_heightmap(hm: Heightmap, out: Path) -> None:
    """Write heightmap.png / .tif / .json into the (existing) directory ``out``."""
    import rasterio
    from PIL import Image

    q, _, _, _ = png16(hm.heights)
    Image.fromarray(q).save(out / "heightmap.png", optimize=False)
    n = hm.size
    profile = {"driver": "GTiff", "width": n, "height": n, "count": 1, "dtype": "float32", "crs": hm.grid_crs,
               "transform": hm.transform, "compress": "deflate", "predictor": 3, "nodata": None}
    if n >= 256:
        profile.update(tiled=True, blockxsize=256, blockysize=256)
    with rasterio.open(out / "heightmap.tif", "w", **profile) as dst:
        dst.write(hm.heights.astype(np.float32), 1)
        dst.units = ("metre",)
        dst.update_tags(AREA_OR_POINT="Area", VINECLI="heightmap: cell centres are the vertices; heights in metres")
    meta = dict(hm.meta)
    meta["files"] = {"png": "heightmap.png", "tif": "heightmap.tif"}
    write_json(out / "heightmap.json", meta)


def _tif_crs(meta: DsmMeta, crop: SquareCrop) -> Any:
    """CRS written into heightmap.tif: the grid CRS, without a vertical part whose unit was converted."""
    from rasterio.crs import CRS

    if crop.grid_crs is None:
        return None
    if meta.units.z_to_m != 1.0 and not meta.units.geographic:
        return CRS.from_wkt(horizontal_crs(crop.grid_crs).to_wkt())
    return crop.grid_crs


# parameters: keyword-only options, each with its default, one per `vinecli terrain convert --to heightmap` option; a caller names the ones it sets
def convert_to_heightmap(dsm: Path, out: Path, *, size: int | None = None, method: str = HEIGHTMAP_METHOD,
                         window: tuple[int, int, int, int] | None = None,
                         bbox: tuple[float, float, float, float] | None = None, fill: str | float = FILL,
                         z_unit: str | None = None, overwrite: bool = False) -> Heightmap:
    """DSM GeoTIFF -> ``out``/heightmap.{png,tif,json} + manifest.json, written atomically.

    ``size``: N = 2^n+1 (<= 1025, PyBullet's 2^21-sample limit), None = suggested. ``method``:
    bilinear | cubic | average | max | nearest. ``window``: (col, row, width, height) pixels;
    ``bbox``: (minx, miny, maxx, maxy) DSM CRS units. ``fill``: idw | nearest | min | metres.
    ``z_unit``: m | ft | us-ft to override the vertical unit. Raises InputError/TerrainError/
    OutputError (exit 2) on bad input, leaving nothing in ``out``.
    """
    dsm, out = Path(dsm), Path(out)
    check_out_dir(out, overwrite=overwrite, inputs=[dsm])
    manifest = Manifest("terrain convert --to heightmap", inputs=[dsm], parameters={
        "size": size, "method": method, "window": window, "bbox": bbox, "fill": fill, "z_unit": z_unit})
    with manifest.stage("heightmap"):
        hm = build_heightmap(dsm, size, method=method, window=window, bbox=bbox, fill=fill, z_unit=z_unit)
    manifest.parameters["size"] = hm.size
    with atomic_output_dir(out, manifest, overwrite=overwrite) as tmp, manifest.stage("write"):
        write_heightmap(hm, tmp)
    hm.dir = out
    return hm


def load_heightmap(directory: Path) -> Heightmap:
    """Load a heightmap directory (heightmap.json + heightmap.tif) for the world builder.

    Heights come from the float32 GeoTIFF (exact, not the 16-bit PNG). InputError if missing or
    inconsistent.
    """
    import rasterio

    directory = Path(directory)
    meta = read_format_json(directory, "heightmap", FORMAT)
    tif = directory / "heightmap.tif"
    if not tif.is_file():
        raise InputError("heightmap.tif missing", path=directory)
    with rasterio.open(tif) as src:
        heights = src.read(1).astype(np.float32)
        grid_crs, transform = (src.crs if src.crs else None), src.transform
    n = int(meta["size_px"])
    if heights.shape != (n, n):
        raise InputError(f"heightmap.tif is {heights.shape}, heightmap.json says {n}x{n}", path=tif)
    go = meta.get("geodetic_origin")
    origin = GeoOrigin.from_dict(go) if go else None
    return Heightmap(heights, float(meta["spacing_m"]), origin, meta, directory, grid_crs, transform)
