"""Terrain benchmarks: heightmap vs gdalwarp, tiles vs whole-raster pydelatin, peak memory.

Usage: ``python benchmarks/terrain.py [--quick] [--stages heightmap,tiles,memory] [--json OUT]``

Stages (each prints one table with ratios; ``--quick`` shrinks every size for a smoke run):

* ``heightmap``: a 2049² DSM (matplotlib's real ``jacksboro_fault_dem`` SRTM sample, cubic-upsampled
  to 1 m pixels, as in docs/terrain.md) -> 1025² with vinecli vs ``gdalwarp`` doing the same crop and
  resampling. Half-pixel convention: vinecli's vertices sit *on* the crop edges (first/last vertex =
  first/last pixel centre), so the heightmap is a raster of cells *centred* on the vertices whose
  extent is the crop grown by half a cell. ``gdalwarp -te <crop> -ts N N`` instead makes the crop
  the cells' outer edges, shifting every sample half a cell inwards; ``gdalwarp -te <crop ± d/2>``
  is the same grid as vinecli's. Both are shown, with RMS against the exact DSM samples at the
  vertices (2049 -> 1025: every other pixel).
* ``tiles``: 2049² at E = 0.1 m in 8×8 tiles of 256 px (shared borders) vs single-process
  whole-raster pydelatin: meshing time, full command time (meshing + stitching + error
  measurement at every sample + OBJ export) vs the same work done on the whole raster in one
  process, triangles vs the full grid, measured max error, max border gap (and the gap the
  per-tile meshes have before stitching).
* ``memory``: a 16385² float32 DSM (1 GiB, written in strips to /tmp) -> 1025² heightmap in a
  child process; peak RSS of the child (``VmHWM`` read by the child, and ``getrusage`` of the
  children in this process) vs the raster size; target < 1.5 GiB.
* ``reconstruct`` (point clouds): belongs to the point-cloud pipeline; add it to :data:`STAGES`
  here or as ``benchmarks/reconstruct.py``.

Run only ``--quick`` on a shared machine; the full run needs ~2 GB of free RAM and ~1.1 GB in /tmp.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

Row = dict[str, Any]


def jacksboro_dsm(path: Path, n: int) -> np.ndarray:
    """matplotlib's SRTM sample (344×403) cubic-upsampled to n×n float32, 1 m pixels, UTM 33N,
    heights rescaled to 56 m of relief (the setup of docs/terrain.md)."""
    import rasterio
    from matplotlib import cbook
    from rasterio.transform import from_origin
    from scipy import ndimage

    dem = cbook.get_sample_data("jacksboro_fault_dem.npz")["elevation"].astype(np.float64)
    dem = 200.0 + (dem - dem.min()) * 56.0 / (dem.max() - dem.min())
    z = ndimage.zoom(dem, (n / dem.shape[0], n / dem.shape[1]), order=3).astype(np.float32)[:n, :n]
    with rasterio.open(path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32633",
                       transform=from_origin(500000.0, 5000000.0, 1.0, 1.0), tiled=True, blockxsize=256,
                       blockysize=256) as dst:
        dst.write(z, 1)
    return z


def _timed(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _read(path: Path) -> np.ndarray:
    import rasterio

    with rasterio.open(path) as ds:
        return ds.read(1).astype(np.float64)


def bench_heightmap(quick: bool, work: Path) -> list[Row]:
    """vinecli convert --to heightmap vs gdalwarp (aligned and naive extents)."""
    from vinecli.terrain.heightmap import convert_to_heightmap

    side = 513 if quick else 2049
    n = (side - 1) // 2 + 1
    src = work / "jacksboro.tif"
    z = jacksboro_dsm(src, side)
    exact = z[::2, ::2].astype(np.float64)  # vertices fall on every other pixel centre
    repeat = 1 if quick else 3
    rows: list[Row] = []
    for method in ("bilinear", "cubic", "max"):
        out = work / f"hm-{method}"

        def ours(out: Path = out, method: str = method) -> Any:
            shutil.rmtree(out, ignore_errors=True)
            return convert_to_heightmap(src, out, size=n, method=method)

        t_ours, hm = _timed(ours, repeat)
        t = hm.transform
        aligned = [t.c, t.f + t.e * n, t.c + t.a * n, t.f]
        x0, y0, x1, y1 = hm.meta["bounds"]
        results = {}
        for name, te in (("aligned", aligned), ("naive", [x0, y0, x1, y1])):
            dst = work / f"gw-{method}-{name}.tif"

            def gw(te: list[float] = te, dst: Path = dst, method: str = method) -> None:
                subprocess.run(["gdalwarp", "-q", "-overwrite", "-r", method, "-te", *map(repr, te), "-ts", str(n),
                                str(n), "-ot", "Float32", str(src), str(dst)], check=True)

            t_gw, _ = _timed(gw, repeat)
            results[name] = (t_gw, _read(dst))
        h = hm.heights.astype(np.float64)
        t_gw, g = results["aligned"]
        _, naive = results["naive"]
        rms = lambda a: float(np.sqrt(np.mean(a**2)))  # noqa: E731
        rows.append({
            "method": method, "grid": f"{side}² -> {n}²",
            "vinecli_s": t_ours, "gdalwarp_s": t_gw, "time_ratio_vinecli/gdalwarp": t_ours / t_gw,
            "rms_vs_gdalwarp_aligned_m": rms(h - g), "rms_vs_gdalwarp_naive_m": rms(h - naive),
            "rms_vinecli_vs_exact_m": rms(h - exact), "rms_gdalwarp_naive_vs_exact_m": rms(naive - exact),
            "target_rms_m": 0.001,
        })
    return rows


def _tin_pipeline_whole(z: np.ndarray, e: float, out: Path) -> tuple[float, float, Any]:
    """Whole-raster pydelatin in one process, then the same measurement and OBJ export as per tile."""
    from vinecli.terrain.tin import export_mesh, mesh_grid, tin_error

    t0 = time.perf_counter()
    tin = mesh_grid(z, 0, 0, e, None)
    t_mesh = time.perf_counter() - t0
    mx, _, _, _ = tin_error(tin, z, 0, 0)
    h, w = z.shape
    export_mesh(tin, z, 0, 0, (-(w - 1) / 2, 1.0), ((h - 1) / 2, -1.0), out, "obj")
    return t_mesh, time.perf_counter() - t0, (tin, mx)


def bench_tiles(quick: bool, work: Path) -> list[Row]:
    """convert --to tiles (8×8 tiles, process pool) vs single-process whole-raster pydelatin."""
    from vinecli.terrain.tiles import _stitch, border_gap, convert_to_tiles, split_edges
    from vinecli.terrain.tin import mesh_grid

    side, tile_px = (513, 64) if quick else (2049, 256)
    e = 0.1
    src = work / "jacksboro-tiles.tif"
    z = jacksboro_dsm(src, side)
    out = work / "tiles"
    shutil.rmtree(out, ignore_errors=True)
    t0 = time.perf_counter()
    ts = convert_to_tiles(src, out, max_error=e, tile_px=tile_px)
    t_cmd = time.perf_counter() - t0
    m = ts.meta
    alt = m["origin"]["alt_m"]
    zrel = (z - np.float32(alt)).astype(np.float32)
    t_whole_mesh, t_whole_all, (whole, whole_err) = _tin_pipeline_whole(zrel, e * (1 - 1e-4), work / "whole.obj")
    # the gap independent per-tile meshes would leave without the shared-vertex stitch
    edges = split_edges(side - 1, tile_px)
    raw = {(i, j): mesh_grid(zrel[edges[i]:edges[i + 1] + 1, edges[j]:edges[j + 1] + 1], edges[j], edges[i],
                             e * (1 - 1e-4), None)
           for i in range(len(edges) - 1) for j in range(len(edges) - 1)}
    gap_raw = max(border_gap(raw[(i, j)], raw[(i, j + 1)], "col", edges[j + 1], zrel)
                  for i in range(len(edges) - 1) for j in range(len(edges) - 2))
    stitched = _stitch(raw, edges, edges)
    gap_stitched = max(border_gap(stitched[(i, j)], stitched[(i, j + 1)], "col", edges[j + 1], zrel)
                       for i in range(len(edges) - 1) for j in range(len(edges) - 2))
    tiles_n = len(edges) - 1
    full = 2 * (side - 1) ** 2
    mesh_s = m["seconds"].get("mesh", float("nan"))
    return [{
        "grid": f"{side}², {tiles_n}x{tiles_n} tiles of {tile_px} px, E={e} m, workers={m['workers']}",
        "tiles_mesh_s": mesh_s, "whole_pydelatin_s": t_whole_mesh, "mesh_time_ratio_tiles/whole": mesh_s / t_whole_mesh,
        "tiles_command_s": t_cmd, "whole_mesh+measure+obj_s": t_whole_all,
        "command_time_ratio_tiles/whole": t_cmd / t_whole_all,
        "triangles_tiles": m["totals"]["triangles"], "triangles_whole": int(whole.tris.shape[0]),
        "triangles_full_grid": full, "triangle_ratio_vs_full_grid": m["totals"]["triangles"] / full,
        "measured_max_error_m": m["totals"]["max_error_m"], "whole_max_error_m": whole_err,
        "max_border_gap_m": m["totals"]["max_border_gap_m"], "gap_before_stitch_m": gap_raw,
        "gap_after_stitch_m": gap_stitched, "seconds_by_stage": m["seconds"],
    }]


_MEM_CHILD = """
import json, re, sys, time
from pathlib import Path
from vinecli.terrain.heightmap import convert_to_heightmap
t0 = time.perf_counter()
hm = convert_to_heightmap(Path(sys.argv[1]), Path(sys.argv[2]), size=int(sys.argv[3]), method=sys.argv[4])
hwm = int(re.search(r"VmHWM:\\s+(\\d+) kB", open("/proc/self/status").read()).group(1))
print(json.dumps({"read": hm.meta["read"], "vmhwm_kib": hwm, "seconds": time.perf_counter() - t0}))
"""


def bench_memory(quick: bool, work: Path) -> list[Row]:
    """Peak RSS of a child converting a large float32 DSM to a 1025² (quick: 257²) heightmap."""
    import rasterio
    from rasterio.transform import from_origin
    from rasterio.windows import Window

    side, size = (8193, 257) if quick else (16385, 1025)
    tmp = Path(tempfile.mkdtemp(prefix="vinecli-bench-mem-", dir="/tmp"))
    try:
        path = tmp / "large.tif"
        t0 = time.perf_counter()
        with rasterio.open(path, "w", driver="GTiff", width=side, height=side, count=1, dtype="float32",
                           crs="EPSG:32633", transform=from_origin(0, side * 0.25, 0.25, 0.25), tiled=True,
                           blockxsize=512, blockysize=512) as dst:
            x = np.arange(side, dtype=np.float32)
            for r0 in range(0, side, 512):
                r = np.arange(r0, min(side, r0 + 512), dtype=np.float32)
                block = 100 + 0.001 * x[None, :] + 0.3 * np.sin(r[:, None] * 0.01) + 0.5 * ((x[None, :] % 37) < 2)
                dst.write(block.astype(np.float32), 1, window=Window(0, r0, side, r.size))
        t_gen = time.perf_counter() - t0
        rows = []
        for method in ("bilinear", "max"):
            out = tmp / f"hm-{method}"
            before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
            r = subprocess.run([sys.executable, "-c", _MEM_CHILD, str(path), str(out), str(size), method],
                               capture_output=True, text=True, check=True,
                               env={**os.environ, "PYTHONPATH": str(REPO)})
            after = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
            child = json.loads(r.stdout.strip().splitlines()[-1])
            raster_mib = side * side * 4 / 2**20
            peak = child["vmhwm_kib"] / 1024
            rows.append({
                "raster": f"{side}² float32 ({raster_mib:.0f} MiB, written in {t_gen:.1f} s)", "heightmap": f"{size}²",
                "method": method, "read": child["read"], "seconds": child["seconds"], "peak_rss_mib": peak,
                "getrusage_children_maxrss_mib": max(after, before) / 1024,
                "peak/raster": peak / raster_mib, "limit_mib": 1536, "ok": peak < 1536,
            })
        return rows
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


#: Benchmark stages by name. Point clouds: the point-cloud pipeline adds ``reconstruct`` here
#: (or ships benchmarks/reconstruct.py).
STAGES: dict[str, Callable[[bool, Path], list[Row]]] = {
    "heightmap": bench_heightmap,
    "tiles": bench_tiles,
    "memory": bench_memory,
}


def render(name: str, rows: list[Row]) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"terrain benchmark: {name}", title_justify="left")
    table.add_column("metric", style="bold")
    for i in range(len(rows)):
        table.add_column(str(rows[i].get("method", i + 1)))
    keys = [k for k in rows[0] if k != "method"]
    for k in keys:
        cells = []
        for r in rows:
            v = r.get(k)
            cells.append(f"{v:.4g}" if isinstance(v, float) else json.dumps(v) if isinstance(v, dict) else str(v))
        table.add_row(k, *cells)
    Console().print(table)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run with small rasters")
    ap.add_argument("--stages", default=",".join(STAGES), help=f"comma-separated subset of {', '.join(STAGES)}")
    ap.add_argument("--json", type=Path, help="also write the results as JSON")
    args = ap.parse_args()
    names = [s for s in args.stages.split(",") if s]
    unknown = [s for s in names if s not in STAGES]
    if unknown:
        ap.error(f"unknown stage(s) {unknown}; choose from {list(STAGES)}")
    results: dict[str, Any] = {"quick": args.quick, "cpus": len(os.sched_getaffinity(0))}
    with tempfile.TemporaryDirectory(prefix="vinecli-bench-terrain-") as d:
        for name in names:
            work = Path(d) / name
            work.mkdir()
            rows = STAGES[name](args.quick, work)
            results[name] = rows
            render(name, rows)
    if args.json:
        args.json.write_text(json.dumps(results, indent=2, default=str) + "\n")


if __name__ == "__main__":
    main()
