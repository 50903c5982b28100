"""Point cloud -> mesh: seconds per stage, holes before/after filling, BPA vs 2.5-D Delaunay.

A synthetic terrain cloud (tests/pointcloud_synth.py: rolling hills, uniformly random x-y at
1 point/m², sigma 2 cm noise, UTM-sized coordinates; 1,000,000 points, 20,000 with ``--quick``) is written
as LAZ and run through :func:`vinecli.terrain.pointcloud.reconstruct.reconstruct_cloud` twice: ball pivoting
(radii [2d, 4d, 8d], then hole filling) and ``delaunay25d``. Prints one row per method with the
per-stage seconds, and the BPA / Delaunay time ratio. A small warm-up run first keeps import
times (Open3D, SciPy) out of the numbers. Run the full size on a quiet machine only.

    .venv/bin/python benchmarks/reconstruct.py [--quick] [--points N] [--voxel M] [--json out.json]

``--voxel`` passes a voxel edge (m) to both runs (0 = mesh every point); by default the
pipeline's own default (2 x median NN spacing) applies.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))


def main() -> None:
    import numpy as np

    from tests.pointcloud_synth import random_terrain_cloud, read_obj, surface_at, terrain_cloud, write_las
    from vinecli.terrain.pointcloud.reconstruct import ReconstructOptions, reconstruct_cloud

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="20,000 points: a smoke run")
    ap.add_argument("--points", type=int, default=None, help="number of points (default 1,000,000)")
    ap.add_argument("--voxel", type=float, default=None, help="voxel edge in m for both runs (0 = none)")
    ap.add_argument("--json", type=Path, default=None, help="also write the results as JSON")
    args = ap.parse_args()
    n = args.points or (20_000 if args.quick else 1_000_000)
    side = math.sqrt(n)
    with tempfile.TemporaryDirectory(prefix="vinecli-bench-reconstruct-") as tmp:
        tmpdir = Path(tmp)
        t0 = time.perf_counter()
        cloud = random_terrain_cloud(n, math.sqrt(n), noise=0.02, seed=42)
        path = write_las(tmpdir / "terrain.laz", cloud)
        print(f"cloud: {len(cloud):,} points over {side:.0f} m x {side:.0f} m, written in {time.perf_counter() - t0:.2f} s "
              f"({path.stat().st_size / 1e6:.1f} MB LAZ)")
        warm = write_las(tmpdir / "warm.laz", terrain_cloud(30, 30))
        for method in ("bpa", "delaunay25d"):
            reconstruct_cloud(warm, tmpdir / f"warm-{method}", ReconstructOptions(method=method))
        results = {}
        for method in ("bpa", "delaunay25d"):
            t0 = time.perf_counter()
            stats = reconstruct_cloud(path, tmpdir / method, ReconstructOptions(method=method, voxel=args.voxel))
            wall = time.perf_counter() - t0
            v, _ = read_obj(tmpdir / method / "mesh.obj")
            w = v + np.asarray(stats["offset_m"])
            err = w[:, 2] - surface_at(w)
            results[method] = {
                "wall_s": wall,
                "seconds": stats["seconds"],
                "points_used": stats["points"]["used"],
                "voxel_m": stats["voxel_m"],
                "d_m": stats["spacing_m"]["d"],
                "triangles": stats["mesh"]["triangles"],
                "holes_before": stats["holes_before"],
                "holes_after": stats["holes_after"],
                "components": stats["mesh"]["components"],
                "non_manifold_edges": stats["mesh"]["non_manifold_edges"],
                "unused_points": stats["mesh"]["unused_points"],
                "vertex_rms_error_m": float(np.sqrt(np.mean(err**2))),
            }
    for method, r in results.items():
        print(f"\n{method}: {r['points_used']:,} points used (voxel {r['voxel_m']:.3f} m, d {r['d_m']:.3f} m), "
              f"{r['triangles']:,} triangles, holes {r['holes_before']} -> {r['holes_after']}, "
              f"{r['components']} component(s), {r['non_manifold_edges']} non-manifold edges, "
              f"vertex RMS error {r['vertex_rms_error_m'] * 1000:.1f} mm, wall {r['wall_s']:.2f} s")
        print("  " + ", ".join(f"{k} {v:.3f}" for k, v in r["seconds"].items()))
    mesh_b = sum(v for k, v in results["bpa"]["seconds"].items() if k in ("normals", "bpa", "fill_holes"))
    mesh_d = results["delaunay25d"]["seconds"]["delaunay"]
    ratio_total = results["bpa"]["seconds"]["total"] / results["delaunay25d"]["seconds"]["total"]
    print(f"\nBPA / delaunay25d time ratio: total {ratio_total:.2f}x; meshing only "
          f"(normals + BPA + fill_holes vs Delaunay) {mesh_b / mesh_d:.2f}x")
    if args.json:
        args.json.write_text(json.dumps({"points": len(cloud), "quick": args.quick, "results": results,
                                         "ratio_total": ratio_total, "ratio_meshing": mesh_b / mesh_d}, indent=2))


if __name__ == "__main__":
    main()
