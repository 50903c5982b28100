"""``terrain convert --to tiles``: DSM -> crack-free, error-bounded mesh tiles + tiles.json.

The whole raster (not a square) is cut into tiles of at most ``tile_px`` pixel *intervals* per
side that share their border row/column (a tile of step 256 holds 257×257 samples). Each tile is
triangulated with pydelatin (:mod:`~vinecli.terrain.tin`) in a spawned process pool. Neighbouring
tiles then get the union of their border vertices (boundary triangles split into fans), so both
sides of every border are the same polyline: no cracks, no skirts. Every tile is then measured
against the raster at every sample it covers; with ``max_error`` as the control the measured
maximum must be <= ``max_error`` on every tile (tiles that exceed it after stitching are re-meshed
tighter; if that fails the command raises :class:`~vinecli.errors.RuntimeFailure`).

Frame of the meshes: local metres, x east, y north, z up, relative to the origin in tiles.json
(the centre of the raster bounds; z relative to ``origin.alt_m``, the height there). Geographic
rasters use metres per degree at the centre latitude (an equirectangular approximation, fine at
field scale). Heights are nodata-filled first (:mod:`~vinecli.terrain.fill`); errors are measured
against the filled raster.
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Callable, Iterable
from concurrent.futures import Executor, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from vinecli.errors import InputError, RuntimeFailure
from vinecli.geo import GeoOrigin
from vinecli.outputs import Manifest, atomic_output_dir, write_json
from vinecli.terrain.defaults import FILL, MAX_TILES, MIN_TILE_PX, TILE_FORMAT, TILE_PX
from vinecli.terrain.fill import fill_nodata, parse_fill
from vinecli.terrain.raster import (
    check_out_dir,
    gdal_env,
    inspect_dsm,
    open_raster,
    read_format_json,
    read_heights,
    to_lonlat,
)
from vinecli.terrain.tin import Tin, finish_task, mesh_task, split_border

log = logging.getLogger(__name__)

FORMAT = "vinecli-tiles/1"
MESH_FORMATS: tuple[str, ...] = ("obj", "stl")
DEFAULT_MAX_ERROR = 0.1
#: Below this many raster samples the pool's start-up costs more than it saves.
POOL_MIN_SAMPLES = 500_000
#: pydelatin is asked for a slightly tighter bound so float32 rounding cannot exceed the user's.
MESH_MARGIN = 1e-4
MAX_REMESH_ROUNDS = 4

T = TypeVar("T")
R = TypeVar("R")


@dataclass(frozen=True)
class TileInfo:
    """One tile of a tile set: its mesh file (absolute path) and tiles.json entry."""

    path: Path
    row: int
    col: int
    bounds_m: tuple[float, float, float, float, float, float]
    triangles: int
    max_error_m: float
    rms_error_m: float
    entry: dict[str, Any]


@dataclass
class TileSet:
    """A tiles directory: origin (None without CRS), tiles, and the tiles.json content."""

    dir: Path
    origin: GeoOrigin | None
    alt_m: float
    tiles: list[TileInfo]
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def bounds_m(self) -> tuple[float, float, float, float, float, float]:
        """(xmin, ymin, zmin, xmax, ymax, zmax) of all tiles, local metres."""
        return tuple(self.meta["totals"]["bounds_m"])  # type: ignore[return-value]


def split_edges(n_intervals: int, step: int) -> list[int]:
    """Tile edges (shared sample indices) dividing ``n_intervals`` into near-equal parts <= step."""
    k = max(1, math.ceil(n_intervals / step))
    return [round(i * n_intervals / k) for i in range(k + 1)]


def default_workers() -> int:
    """Worker processes: the CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _map(ex: Executor | None, fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
    if ex is None:
        return [fn(it) for it in items]
    items = list(items)
    try:
        return list(ex.map(fn, items))
    except BrokenProcessPool as exc:
        # e.g. a __main__ that spawned workers cannot re-import (python - < script)
        log.warning("worker pool failed (%s); meshing in this process", exc)
        return [fn(it) for it in items]


def _stitch(raw: dict[tuple[int, int], Tin], cedges: list[int], redges: list[int]) -> dict[tuple[int, int], Tin]:
    """Give both tiles of every shared border the union of their border vertices."""
    tins = dict(raw)
    nr, nc = len(redges) - 1, len(cedges) - 1
    for i in range(nr):
        for j in range(nc - 1):  # vertical border at column cedges[j+1]
            a, b, line = (i, j), (i, j + 1), cedges[j + 1]
            want = np.union1d(tins[a].rows[tins[a].cols == line], tins[b].rows[tins[b].cols == line])
            tins[a] = split_border(tins[a], "col", line, want)
            tins[b] = split_border(tins[b], "col", line, want)
    for i in range(nr - 1):
        for j in range(nc):  # horizontal border at row redges[i+1]
            a, b, line = (i, j), (i + 1, j), redges[i + 1]
            want = np.union1d(tins[a].cols[tins[a].rows == line], tins[b].cols[tins[b].rows == line])
            tins[a] = split_border(tins[a], "row", line, want)
            tins[b] = split_border(tins[b], "row", line, want)
    return tins


def border_gap(a: Tin, b: Tin, axis: str, line: int, z: np.ndarray) -> float:
    """Largest vertical gap (m) between two tiles' polylines along their shared border.

    Each border vertex of one tile is compared with the other tile's border polyline there.
    """
    def poly(t: Tin) -> tuple[np.ndarray, np.ndarray]:
        on = (t.cols if axis == "col" else t.rows) == line
        pos = (t.rows if axis == "col" else t.cols)[on]
        order = np.argsort(pos)
        pos = pos[order]
        zz = z[t.rows[on][order], t.cols[on][order]].astype(np.float64)
        return pos.astype(np.float64), zz

    pa, za = poly(a)
    pb, zb = poly(b)
    return float(max(np.max(np.abs(np.interp(pa, pb, zb) - za)), np.max(np.abs(np.interp(pb, pa, za) - zb))))


def _borders(cedges: list[int], redges: list[int]) -> list[tuple[tuple[int, int], tuple[int, int], str, int]]:
    nr, nc = len(redges) - 1, len(cedges) - 1
    out = [((i, j), (i, j + 1), "col", cedges[j + 1]) for i in range(nr) for j in range(nc - 1)]
    out += [((i, j), (i + 1, j), "row", redges[i + 1]) for i in range(nr - 1) for j in range(nc)]
    return out


# parameters: keyword-only options, each with its default, one per `vinecli terrain convert --to tiles` option; a caller names the ones it sets
def convert_to_tiles(dsm: Path, out: Path, *, max_error: float | None = None, max_triangles: int | None = None,
                     tile_px: int = TILE_PX, fmt: str = TILE_FORMAT, fill: str | float = FILL, z_unit: str | None = None,
                     workers: int | None = None, overwrite: bool = False) -> TileSet:
    """DSM GeoTIFF -> ``out``/tiles/*.obj (or .stl) + tiles.json + manifest.json, atomically.

    ``max_error`` (m): vertical error bound per tile (default 0.1 unless only ``max_triangles``
    is given); ``max_triangles``: pydelatin triangle budget per tile (border stitching may add a
    few); ``tile_px``: tile step in pixel intervals (tiles share borders); ``fmt``: obj | stl
    (binary); ``fill``: idw | nearest | min | metres; ``workers``: processes (default: CPUs).
    """
    t_start = time.perf_counter()
    dsm, out = Path(dsm), Path(out)
    fill = parse_fill(fill, path=dsm)
    if fmt not in MESH_FORMATS:
        raise InputError(f"--format {fmt!r}: choose {' or '.join(MESH_FORMATS)}", path=dsm)
    if tile_px < MIN_TILE_PX:
        raise InputError(f"--tile-px {tile_px}: need at least {MIN_TILE_PX}", path=dsm)
    if max_error is not None and not (max_error > 0 and math.isfinite(max_error)):
        raise InputError(f"--max-error {max_error}: need a positive number of metres", path=dsm)
    if max_triangles is not None and max_triangles < 2:
        raise InputError(f"--max-triangles {max_triangles}: need at least 2", path=dsm)
    bounded = max_triangles is None
    if max_error is None:
        max_error = DEFAULT_MAX_ERROR if max_triangles is None else 0.0
    check_out_dir(out, overwrite=overwrite, inputs=[dsm])
    manifest = Manifest("terrain convert --to tiles", inputs=[dsm], parameters={
        "max_error": max_error, "max_triangles": max_triangles, "tile_px": tile_px, "format": fmt, "fill": fill,
        "z_unit": z_unit})
    with manifest.stage("read"), gdal_env(), open_raster(dsm) as src:
        meta = inspect_dsm(src, z_unit=z_unit)
        n_tiles = (len(split_edges(meta.width - 1, tile_px)) - 1) * (len(split_edges(meta.height - 1, tile_px)) - 1)
        if n_tiles > MAX_TILES:
            raise InputError(f"--tile-px {tile_px} cuts the {meta.width} x {meta.height} px raster into {n_tiles:,} "
                             f"tiles (at most {MAX_TILES:,}): use a larger --tile-px", path=dsm)
        z, valid = read_heights(src, meta)
    del valid
    with manifest.stage("fill"):
        fres = fill_nodata(z, fill, path=dsm)
    h, w = z.shape
    from scipy.ndimage import map_coordinates

    alt = float(np.float32(map_coordinates(z.astype(np.float64), [[(h - 1) / 2], [(w - 1) / 2]], order=1)[0]))
    z -= np.float32(alt)
    cx, cy = meta.centre
    origin = None
    if meta.crs is not None:
        lon, lat = to_lonlat(meta.crs, cx, cy)
        origin = GeoOrigin(float(lat), float(lon), alt)
    dx, dy = meta.pixel_size_m()
    xcol = (-(w - 1) / 2 * dx, dx)
    yrow = ((h - 1) / 2 * dy, -dy)
    cedges, redges = split_edges(w - 1, tile_px), split_edges(h - 1, tile_px)
    keys = [(i, j) for i in range(len(redges) - 1) for j in range(len(cedges) - 1)]

    def sub(k: tuple[int, int]) -> tuple[np.ndarray, int, int]:
        i, j = k
        c0, c1, r0, r1 = cedges[j], cedges[j + 1], redges[i], redges[i + 1]
        return z[r0:r1 + 1, c0:c1 + 1], c0, r0

    n_workers = min(workers or default_workers(), len(keys))
    use_pool = n_workers > 1 and w * h >= POOL_MIN_SAMPLES
    pool_ctx: Any = nullcontext(None)
    if use_pool:
        import multiprocessing as mp

        pool_ctx = ProcessPoolExecutor(max_workers=n_workers, mp_context=mp.get_context("spawn"))
    else:
        n_workers = 1
    e_mesh = {k: max_error * (1 - MESH_MARGIN) for k in keys}
    stats: dict[tuple[int, int], dict[str, Any]] = {}
    gaps: list[float] = []
    with pool_ctx as ex:
        with manifest.stage("mesh"):
            raw = dict(zip(keys, _map(ex, mesh_task, [(*sub(k), e_mesh[k], max_triangles) for k in keys]),
                           strict=True))
        with atomic_output_dir(out, manifest, overwrite=overwrite) as tmp:
            (tmp / "tiles").mkdir()
            todo = list(keys)
            for rnd in range(MAX_REMESH_ROUNDS + 1):
                with manifest.stage("stitch"):
                    tins = _stitch(raw, cedges, redges)
                with manifest.stage("measure+write"):
                    tasks = [(tins[k], *sub(k), xcol, yrow,
                             str(tmp / "tiles" / f"tile_r{k[0]:02d}_c{k[1]:02d}.{fmt}"), fmt) for k in todo]
                    for k, res in zip(todo, _map(ex, finish_task, tasks), strict=True):
                        stats[k] = res
                bad = [k for k in keys if stats[k]["uncovered_samples"] or
                       (bounded and stats[k]["max_error_m"] > max_error)]
                if not bad:
                    break
                if rnd == MAX_REMESH_ROUNDS:
                    k = bad[0]
                    raise RuntimeFailure(
                        f"tile r{k[0]} c{k[1]}: measured max error {stats[k]['max_error_m']:.6g} m > {max_error:g} m "
                        f"(uncovered samples: {stats[k]['uncovered_samples']}) after {rnd} re-meshing rounds",
                        path=dsm)
                log.info("round %d: %d tile(s) above the bound after stitching; re-meshing tighter", rnd + 1, len(bad))
                for k in bad:
                    e_mesh[k] *= 0.5
                with manifest.stage("mesh"):
                    for k, tin in zip(bad, _map(ex, mesh_task, [(*sub(k), e_mesh[k], max_triangles) for k in bad]),
                                      strict=True):
                        raw[k] = tin
                dirty = {(k[0] + di, k[1] + dj) for k in bad for di in (-1, 0, 1) for dj in (-1, 0, 1)}
                todo = [k for k in keys if k in dirty]
            with manifest.stage("stitch"):
                for a, b, axis, line in _borders(cedges, redges):
                    gaps.append(border_gap(tins[a], tins[b], axis, line, z))
            tiles_meta = _tiles_json(_TilesRecord(
                dsm=dsm, meta=meta, keys=keys, tins=tins, stats=stats, e_mesh=e_mesh, cedges=cedges, redges=redges,
                origin=origin, alt=alt, centre=(cx, cy), pix_m=(dx, dy), fres=fres, max_error=max_error,
                max_triangles=max_triangles, bounded=bounded, tile_px=tile_px, fmt=fmt, workers=n_workers,
                max_gap=max(gaps, default=0.0), timings=manifest.timings, seconds=time.perf_counter() - t_start))
            write_json(tmp / "tiles.json", tiles_meta)
    return load_tiles(out)


@dataclass(frozen=True)
class _TilesRecord:
    """What tiles.json records of one conversion (:func:`convert_to_tiles`)."""

    dsm: Path
    meta: Any  # the DSM's DsmMeta (terrain.raster.inspect_dsm)
    keys: list[tuple[int, int]]  # tiles (row, col) in order
    tins: dict[tuple[int, int], Tin]
    stats: dict[tuple[int, int], dict[str, Any]]  # each tile's measured errors and bounds (finish_task)
    e_mesh: dict[tuple[int, int], float]  # the vertical error each tile was meshed to, m
    cedges: list[int]  # tile borders, raster columns
    redges: list[int]  # tile borders, raster rows
    origin: GeoOrigin | None  # geodetic origin at the raster centre (None: no CRS)
    alt: float  # raster height at the centre, m
    centre: tuple[float, float]  # raster centre, CRS x, y
    pix_m: tuple[float, float]  # pixel size, m
    fres: Any  # the nodata fill (terrain.fill.fill_nodata)
    max_error: float  # the vertical error bound, m (0: none)
    max_triangles: int | None
    bounded: bool  # the error bound enforced (no triangle budget)
    tile_px: int
    fmt: str  # mesh format, obj or stl
    workers: int
    max_gap: float  # largest gap along a tile border, m
    timings: dict[str, float]  # seconds per stage
    seconds: float  # in all


def _tiles_json(r: _TilesRecord) -> dict[str, Any]:
    """The tiles.json document of a conversion."""
    dsm, meta, keys, tins, stats, e_mesh = r.dsm, r.meta, r.keys, r.tins, r.stats, r.e_mesh
    cedges, redges = r.cedges, r.redges
    origin, alt, centre, pix_m, fres, fmt = r.origin, r.alt, r.centre, r.pix_m, r.fres, r.fmt
    tiles = []
    tri_total = vert_total = samples = 0
    sq = 0.0
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for k in keys:
        i, j = k
        s = stats[k]
        t = tins[k]
        c0, c1, r0, r1 = cedges[j], cedges[j + 1], redges[i], redges[i + 1]
        tiles.append({
            "file": f"tiles/tile_r{i:02d}_c{j:02d}.{fmt}", "row": i, "col": j,
            "window_px": [c0, r0, c1 - c0 + 1, r1 - r0 + 1], "bounds_m": s["bounds_m"],
            "triangles": int(t.tris.shape[0]), "vertices": int(t.cols.size),
            "max_error_m": s["max_error_m"], "rms_error_m": s["rms_error_m"], "samples": s["samples"],
            "mesh_max_error_m": e_mesh[k],
        })
        tri_total += int(t.tris.shape[0])
        vert_total += int(t.cols.size)
        samples += int(s["samples"])
        sq += s["rms_error_m"] ** 2 * s["samples"]
        lo = np.minimum(lo, s["bounds_m"][:3])
        hi = np.maximum(hi, s["bounds_m"][3:])
    h, w = meta.height, meta.width
    full = 2 * (w - 1) * (h - 1)
    horizontal = "CRS units x metres per unit"
    if meta.units.geographic:
        horizontal = f"metres per degree at the centre latitude ({pix_m[0]:.3f} m E-W, {pix_m[1]:.3f} m N-S per pixel)"
    elif meta.crs is None:
        horizontal = "no CRS: coordinates taken as metres"
    return {
        "format": FORMAT,
        "frame": "local metres: x east, y north, z up, relative to origin (z relative to origin.alt_m)",
        "origin": {
            "crs_xy": list(centre), "crs": meta.crs_label, "alt_m": alt,
            "geodetic": origin.to_dict() if origin else None,
            "note": "centre of the raster bounds; alt_m = raster height there (bilinear)" +
                    ("" if origin else "; geodetic origin unknown: the DSM has no CRS"),
        },
        "geodetic_origin": origin.to_dict() if origin else None,
        "horizontal": horizontal,
        "pixel_size_m": list(pix_m),
        "raster_size_px": [w, h],
        "tile_px": r.tile_px,
        "tile_grid": [len(redges) - 1, len(cedges) - 1],
        "mesh_format": fmt,
        "max_error_m": r.max_error if r.max_error > 0 else None,
        "max_triangles": r.max_triangles,
        "error_bound_enforced": r.bounded,
        "error_note": "vertical |mesh - raster| at every raster sample of each tile (nodata-filled raster)",
        "nodata_filled_fraction": fres.filled_fraction,
        "fill_method": fres.method,
        "units": meta.units.to_dict(),
        "source": {"file": str(dsm), "name": dsm.name, "dtype": meta.dtype, "nodata": meta.nodata},
        "warnings": list(meta.warnings),
        "tiles": tiles,
        "totals": {
            "tiles": len(tiles), "triangles": tri_total, "vertices": vert_total, "full_grid_triangles": full,
            "triangle_ratio": tri_total / full, "max_error_m": max(t["max_error_m"] for t in tiles),
            "rms_error_m": math.sqrt(sq / samples) if samples else None, "max_border_gap_m": r.max_gap,
            "bounds_m": [float(v) for v in (*lo, *hi)],
        },
        "workers": r.workers,
        "seconds": {**{k: round(v, 4) for k, v in r.timings.items()}, "total": round(r.seconds, 3)},
    }


def load_tiles(directory: Path) -> TileSet:
    """Load a tiles directory (tiles.json) for the world builder; mesh paths made absolute."""
    directory = Path(directory)
    meta = read_format_json(directory, "tiles", FORMAT)
    tiles = []
    for e in meta["tiles"]:
        p = directory / e["file"]
        if not p.is_file():
            raise InputError(f"tile file {e['file']} missing", path=directory)
        tiles.append(TileInfo(p, int(e["row"]), int(e["col"]), tuple(e["bounds_m"]), int(e["triangles"]),
                              float(e["max_error_m"]), float(e["rms_error_m"]), e))
    geo = meta["origin"].get("geodetic")
    return TileSet(directory, GeoOrigin.from_dict(geo) if geo else None, float(meta["origin"]["alt_m"]), tiles, meta)
