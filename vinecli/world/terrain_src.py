"""Terrain inputs of ``world build``: DSM GeoTIFFs, heightmap and tiles directories.

Everything is turned into a :class:`~vinecli.world.grid.TerrainGrid` in the local ENU frame
(metres about the geodetic origin) plus the files the engine and Gazebo load:

* ``tiles``: error-bounded triangulations (pydelatin) of grid blocks that share their border
  row/column (crack-free, terrain-notes.md §5), one OBJ per tile, normals up;
* ``heightmap``: a square 2^n+1 grid (16-bit PNG for Gazebo, float GeoTIFF, JSON sidecar),
  also the PyBullet heightfield.

Frame: a projected raster's grid axes are taken as ENU axes about the raster centre
(x = easting - centre, y = northing - centre). This neglects the grid convergence of the
projection (≈1.8° for the bundled sample in UTM 16N) and its scale factor (< 0.04 %): at field
scale the terrain is placed within a few decimetres of its true geodetic position. Geographic
rasters (degrees) are converted with the local metres-per-degree at the centre.
The geodetic origin is the raster centre at the DSM's minimum elevation, so terrain z ≥ 0.
"""

from __future__ import annotations

import json
import logging
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import TerrainError
from vinecli.geo import GeoOrigin
from vinecli.world.grid import TerrainGrid

__all__ = ["DsmGrid", "read_dsm", "read_heightmap_dir", "read_tiles_dir", "square_heightmap", "write_heightmap",
           "write_tiles"]

log = logging.getLogger(__name__)


@dataclass
class DsmGrid:
    """A DSM as an ENU height grid plus its geodetic origin and provenance."""

    grid: TerrainGrid
    origin: GeoOrigin
    info: dict[str, Any]


def _fill_nodata(z: np.ndarray, valid: np.ndarray) -> np.ndarray:
    if valid.all():
        return z
    if not valid.any():
        raise TerrainError("raster has no valid height")
    from scipy import ndimage

    idx = ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
    return z[tuple(idx)]


def _block_max(z: np.ndarray, f: int) -> np.ndarray:
    ny, nx = (z.shape[0] // f) * f, (z.shape[1] // f) * f
    return z[:ny, :nx].reshape(ny // f, f, nx // f, f).max(axis=(1, 3))


def read_dsm(path: Path, *, resolution_m: float | None = None, origin: GeoOrigin | None = None) -> DsmGrid:
    """Read a DSM GeoTIFF into an ENU grid (nodata filled by nearest valid, optional max-style downsampling)."""
    import rasterio
    from pyproj import CRS, Transformer

    path = Path(path)
    if not path.is_file():
        raise TerrainError("DSM file not found", path=path)
    try:
        with rasterio.open(path) as ds:
            z = ds.read(1, masked=True)
            transform, crs = ds.transform, ds.crs
    except rasterio.errors.RasterioError as exc:
        raise TerrainError(f"cannot read raster: {exc}", path=path) from None
    if crs is None:
        raise TerrainError("raster has no CRS; cannot place it on the Earth (give it one with gdal_edit.py -a_srs)",
                           path=path)
    if abs(transform.b) > 1e-12 or abs(transform.d) > 1e-12:
        raise TerrainError("rotated rasters are not supported", path=path)
    data = np.asarray(z.filled(np.nan), dtype=np.float64)
    valid = ~np.ma.getmaskarray(z) & np.isfinite(data) & (np.abs(data) < 1e20)
    data = _fill_nodata(np.where(valid, data, 0.0), valid)
    nrows, ncols = data.shape
    px, py = abs(transform.a), abs(transform.e)
    cx_crs = transform.c + transform.a * ncols / 2.0
    cy_crs = transform.f + transform.e * nrows / 2.0
    to_geo = Transformer.from_crs(CRS.from_user_input(crs), "EPSG:4326", always_xy=True)
    lon, lat = to_geo.transform(cx_crs, cy_crs)
    if origin is None:
        origin = GeoOrigin(float(lat), float(lon), float(np.nanmin(data)))
    crs_obj = CRS.from_user_input(crs)
    if crs_obj.is_geographic:
        m_lat, m_lon = GeoOrigin(float(lat), float(lon), 0.0).metres_per_degree
        sx, sy = px * m_lon, py * m_lat
    else:
        unit = crs_obj.axis_info[0].unit_conversion_factor if crs_obj.axis_info else 1.0
        sx, sy = px * unit, py * unit
    if resolution_m is not None and resolution_m > max(sx, sy) * 1.5:
        f = int(round(resolution_m / max(sx, sy)))
        data = _block_max(data, f)
        sx, sy = sx * f, sy * f
    # ENU offset of the origin from the raster centre (when an explicit origin is given)
    ox, oy = 0.0, 0.0
    if origin is not None and (abs(origin.lat - lat) > 1e-9 or abs(origin.lon - lon) > 1e-9):
        e, n, _u = origin.geodetic_to_enu(float(lat), float(lon), origin.alt)
        ox, oy = e, n
    grid_z = data[::-1, :] - origin.alt  # row 0 = south
    ny, nx = grid_z.shape
    x0 = ox - nx * sx / 2.0 + sx / 2.0
    y0 = oy - ny * sy / 2.0 + sy / 2.0
    grid = TerrainGrid(grid_z, x0, y0, sx, sy)
    info = {"dsm": str(path), "crs": crs_obj.to_string(), "pixel_m": [sx, sy], "shape": [ny, nx],
            "elevation_range_m": [float(data.min()), float(data.max())]}
    log.info("DSM %s: %d×%d px of %.3f m, relief %.2f m", path.name, nx, ny, sx, float(data.max() - data.min()))
    return DsmGrid(grid, origin, info)


# ---------------------------------------------------------------------------- tiles
def _tile_mesh(grid: TerrainGrid, i0: int, i1: int, j0: int, j1: int, max_error: float) -> tuple[np.ndarray, np.ndarray]:
    from pydelatin import Delatin

    block = np.ascontiguousarray(grid.z[j0 : j1 + 1, i0 : i1 + 1], dtype=np.float32)
    h, w = block.shape
    tin = Delatin(block, width=w, height=h, max_error=max_error)
    uv = np.asarray(tin.vertices, dtype=np.int64)  # (col, row) within the block
    tri = np.asarray(tin.triangles, dtype=np.int64)
    cols, rows = uv[:, 0], uv[:, 1]
    verts = np.column_stack([
        grid.x0 + (i0 + cols) * grid.dx,
        grid.y0 + (j0 + rows) * grid.dy,
        block[rows, cols].astype(np.float64),
    ])
    # normals up (+z): flip the winding where needed
    a, b, c = verts[tri[:, 0]], verts[tri[:, 1]], verts[tri[:, 2]]
    nz = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    flip = nz < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    return verts, tri


def _write_obj(path: Path, verts: np.ndarray, tri: np.ndarray) -> None:
    with open(path, "w", encoding="ascii") as f:
        f.write("# vinecli terrain tile (ENU metres)\no terrain\n")
        np.savetxt(f, verts, fmt="v %.4f %.4f %.4f")
        np.savetxt(f, tri + 1, fmt="f %d %d %d")


def write_tiles(grid: TerrainGrid, out_dir: Path, *, max_error_m: float, tile_px: int = 256) -> list[Path]:
    """Triangulate ``grid`` in tiles of ``tile_px`` samples sharing borders; write OBJ files into ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    files: list[Path] = []
    manifest: list[dict[str, Any]] = []
    n_tri = 0
    for j0 in range(0, grid.ny - 1, tile_px):
        j1 = min(j0 + tile_px, grid.ny - 1)
        for i0 in range(0, grid.nx - 1, tile_px):
            i1 = min(i0 + tile_px, grid.nx - 1)
            verts, tri = _tile_mesh(grid, i0, i1, j0, j1, max_error_m)
            name = f"tile_{j0 // tile_px:02d}_{i0 // tile_px:02d}.obj"
            _write_obj(out_dir / name, verts, tri)
            files.append(out_dir / name)
            n_tri += len(tri)
            manifest.append({"file": name, "triangles": int(len(tri)),
                             "bounds_enu": [float(verts[:, 0].min()), float(verts[:, 1].min()),
                                            float(verts[:, 0].max()), float(verts[:, 1].max())]})
    log.info("%d tiles, %d triangles (max error %.3f m)", len(files), n_tri, max_error_m)
    (out_dir / "tiles.json").write_text(json.dumps({"max_error_m": max_error_m, "tiles": manifest}, indent=1))
    return files


# ---------------------------------------------------------------------------- heightmap
def square_heightmap(grid: TerrainGrid, size: int) -> TerrainGrid:
    """The centred square of ``grid`` resampled (bilinear) onto ``size``×``size`` vertices (size = 2^n+1)."""
    if size < 3 or (size - 1) & (size - 2):
        raise TerrainError(f"heightmap size must be 2^n + 1, got {size}")
    xmin, ymin, xmax, ymax = grid.bounds
    side = min(xmax - xmin, ymax - ymin)
    cx, cy = (xmin + xmax) / 2.0, (ymin + ymax) / 2.0
    s = np.linspace(-side / 2.0, side / 2.0, size)
    gx, gy = np.meshgrid(cx + s, cy + s)
    z = grid.heights(gx.ravel(), gy.ravel()).reshape(size, size)
    d = side / (size - 1)
    return TerrainGrid(z, cx - side / 2.0, cy - side / 2.0, d, d)


def write_heightmap(grid: TerrainGrid, out_dir: Path, origin: GeoOrigin) -> list[Path]:
    """Write ``heightmap.png`` (16-bit, north up), ``heightmap.tif`` (float32 heights ENU) and ``heightmap.json``."""
    import rasterio
    from affine import Affine

    out_dir.mkdir(parents=True, exist_ok=True)
    zmin, zmax = grid.z_range
    north_up = grid.z[::-1, :]
    span = max(zmax - zmin, 1e-6)
    png16 = np.round((north_up - zmin) / span * 65535.0).astype(np.uint16)
    png = out_dir / "heightmap.png"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(png, "w", driver="PNG", width=grid.nx, height=grid.ny, count=1, dtype="uint16") as ds:
            ds.write(png16, 1)
    aux = png.with_suffix(".png.aux.xml")
    if aux.exists():
        aux.unlink()
    tif = out_dir / "heightmap.tif"
    xmin, _ymin, _xmax, ymax = grid.bounds
    with rasterio.open(tif, "w", driver="GTiff", width=grid.nx, height=grid.ny, count=1, dtype="float32",
                       transform=Affine(grid.dx, 0.0, xmin - grid.dx / 2, 0.0, -grid.dy, ymax + grid.dy / 2)) as ds:
        ds.write(north_up.astype(np.float32), 1)
    side = json.dumps({
        "size_px": grid.nx, "size_m": [(grid.nx - 1) * grid.dx, (grid.ny - 1) * grid.dy],
        "z_min_m": zmin, "z_max_m": zmax, "png_scale": "z = z_min + png / 65535 * (z_max - z_min)",
        "centre_enu": [(grid.bounds[0] + grid.bounds[2]) / 2, (grid.bounds[1] + grid.bounds[3]) / 2],
        "geodetic_origin": origin.to_dict(), "frame": "ENU metres about geodetic_origin; PNG/TIF north up",
    }, indent=1)
    (out_dir / "heightmap.json").write_text(side)
    return [png, tif, out_dir / "heightmap.json"]


# ---------------------------------------------------------------------------- existing directories
def _origin_from_json(d: dict[str, Any]) -> GeoOrigin | None:
    for key in ("geodetic_origin", "origin_geodetic", "origin"):
        o = d.get(key)
        if isinstance(o, dict) and {"lat", "lon"} <= set(o):
            return GeoOrigin(float(o["lat"]), float(o["lon"]), float(o.get("alt", o.get("alt_m", 0.0))))
        if isinstance(o, dict) and {"lat_deg", "lon_deg"} <= set(o):
            return GeoOrigin(float(o["lat_deg"]), float(o["lon_deg"]), float(o.get("alt_m", 0.0)))
    return None


def read_heightmap_dir(d: Path, origin: GeoOrigin | None) -> tuple[TerrainGrid, GeoOrigin, list[Path]]:
    """A heightmap directory (``heightmap.tif`` float heights + ``heightmap.json`` sidecar)."""
    import rasterio

    tif = next(iter(sorted(Path(d).glob("*.tif"))), None)
    side = next(iter(sorted(Path(d).glob("*.json"))), None)
    if tif is None or side is None:
        raise TerrainError("heightmap directory needs a .tif and a .json sidecar", path=d)
    meta = json.loads(side.read_text())
    o = origin or _origin_from_json(meta)
    if o is None:
        raise TerrainError("no geodetic origin in the sidecar; give origin: in the world file", path=side)
    with rasterio.open(tif) as ds:
        z = ds.read(1).astype(np.float64)
        t = ds.transform
    ny, nx = z.shape
    size_m = meta.get("size_m")
    dx = float(size_m[0]) / (nx - 1) if isinstance(size_m, list) else abs(t.a)
    dy = float(size_m[1]) / (ny - 1) if isinstance(size_m, list) else abs(t.e)
    zoff = 0.0 if meta.get("frame", "").startswith("ENU") else -o.alt
    centre = meta.get("centre_enu", [0.0, 0.0])
    grid = TerrainGrid(z[::-1, :] + zoff, centre[0] - (nx - 1) * dx / 2, centre[1] - (ny - 1) * dy / 2, dx, dy)
    files = sorted(p for p in Path(d).iterdir() if p.suffix in (".png", ".tif", ".json"))
    return grid, o, files


def read_tiles_dir(d: Path, origin: GeoOrigin | None, spacing_m: float = 0.05) -> tuple[TerrainGrid, GeoOrigin, list[Path]]:
    """A tiles directory (``tiles.json`` + OBJ/STL tiles in ENU metres); the height grid is ray-cast."""
    from vinecli.sim.engine import Engine
    from vinecli.world.model import TerrainInfo

    d = Path(d)
    meta_p = d / "tiles.json"
    meta = json.loads(meta_p.read_text()) if meta_p.is_file() else {}
    o = origin or _origin_from_json(meta)
    if o is None:
        raise TerrainError("no geodetic origin in tiles.json; give origin: in the world file", path=d)
    files = sorted(p for p in d.rglob("*") if p.suffix.lower() in (".obj", ".stl"))
    if not files:
        raise TerrainError("no OBJ/STL tiles found", path=d)
    with Engine() as eng:
        bodies = eng.load_terrain(TerrainInfo("tiles", files=files))
        lo = [math.inf] * 3
        hi = [-math.inf] * 3
        for b in bodies:
            a, c = eng.client.getAABB(b)
            lo = [min(lo[k], a[k]) for k in range(3)]
            hi = [max(hi[k], c[k]) for k in range(3)]
        nx = max(2, int((hi[0] - lo[0]) / spacing_m) + 1)
        ny = max(2, int((hi[1] - lo[1]) / spacing_m) + 1)
        xs = np.linspace(lo[0] + 1e-4, hi[0] - 1e-4, nx)
        ys = np.linspace(lo[1] + 1e-4, hi[1] - 1e-4, ny)
        z = np.full((ny, nx), np.nan)
        for j, y in enumerate(ys):
            starts = [[x, y, hi[2] + 1.0] for x in xs]
            ends = [[x, y, lo[2] - 1.0] for x in xs]
            hits = []
            for k in range(0, nx, 4096):
                hits += eng.client.rayTestBatch(starts[k : k + 4096], ends[k : k + 4096])
            z[j] = [h[3][2] if h[0] >= 0 else np.nan for h in hits]
    z = _fill_nodata(np.nan_to_num(z), np.isfinite(z))
    grid = TerrainGrid(z, float(xs[0]), float(ys[0]), float(xs[1] - xs[0]), float(ys[1] - ys[0]))
    return grid, o, files
