"""What a prescription of many small zones costs (docs/dose.md §3): the zone under each point by an STRtree
against the per-zone scan it replaced, and reading the map whole.

A grid of N square zones (random rates 100-300 L/ha, GeoPackage in Web Mercator) over the known-truth vineyard of
the tests (4 rows, 32 m). Measured in this process, interleaved, median of ``--repeats``:

* ``scan``: the zone under each of the rows' points every 5 cm as ``RateMap.mapped`` found it before (a Polygon
  and ``shapely.contains_xy`` per zone, the first zone winning), against ``tree``: ``ZoneIndex.first_zone``
  (built once per map, its build counted); the two must agree point for point;
* ``read``: what ``plan rows --prescription`` does with the map: ``read_prescription`` (count check, read,
  reprojection, overlap check, the field check) and ``segment_rates`` over the measured canopy segments (the map
  asked once per segment);
* with ``--baseline-tree DIR`` (a checkout of the code before, e.g. ``git worktree add /tmp/before main``), the same
  in a subprocess importing DIR's vinecli: the end-to-end ratio;
* the refusal of a map above ``MAX_ZONES`` (from the layer's feature count, before reading).

    .venv/bin/python benchmarks/prescription_zones.py [--zones 2000 20000 100000] [--repeats 3]
                                                       [--baseline-tree DIR] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.append(str(REPO))  # tests' fixtures; after PYTHONPATH (a baseline tree's vinecli)


def field(work: Path) -> tuple[Any, Any, Any]:
    """(georef, rows, canopy segments) of the known-truth vineyard written under ``work``."""
    from tests.canopy_fixtures import write_truth_dsm
    from vinecli.gis.georef import Georef
    from vinecli.rows.dsm_canopy import measure_dsm_canopy

    c = measure_dsm_canopy(write_truth_dsm(work / "vineyard.tif"), base_m=0.5)
    return Georef(c.rows.frame, c.rows.origin), c.rows.detection.rows, c.segments


def write_grid(path: Path, georef: Any, n: int) -> Path:
    """``n`` square zones tiling the field (x -8..8 m, y -16..16 m local), random rates, GeoPackage EPSG:3857."""
    import pyogrio.raw
    from shapely.geometry import Polygon

    nx = int(np.ceil(np.sqrt(n / 2)))
    side = 16.0 / nx
    k = np.arange(n)
    x0, y0 = -8.0 + k % nx * side, -16.0 + k // nx * side
    geoms = [Polygon(georef.to_crs([(a, b), (a + side, b), (a + side, b + side), (a, b + side)], "EPSG:3857")).wkb
             for a, b in zip(x0.tolist(), y0.tolist(), strict=True)]
    rates = np.random.default_rng(1).uniform(100, 300, n).round(1)
    pyogrio.raw.write(path, np.array(geoms, dtype=object), [rates], ["rate"], driver="GPKG", crs="EPSG:3857",
                      geometry_type="Polygon")
    return path


def stations(rows: Any, step: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    from vinecli.rows.canopy_segments import row_stations

    pts = [row_stations(r, np.arange(0.0, float(np.sum(np.hypot(*np.diff(np.asarray(r), axis=0).T))), step))[0]
           for r in rows]
    p = np.concatenate(pts)
    return p[:, 0], p[:, 1]


def scan(zones: list, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The zone under each point as ``RateMap.mapped`` found it before the STRtree (-1: none)."""
    import shapely
    from shapely.geometry import Polygon

    out = np.full(x.shape, -1)
    for k in reversed(range(len(zones))):
        ring, _, _, holes = zones[k]
        out[shapely.contains_xy(Polygon(ring, holes), x, y)] = k
    return out


def read_seconds(path: Path, work: Path) -> float:
    """Seconds of one ``read_prescription`` of ``path`` over the field (default rate 100 L/ha) and its
    ``segment_rates``."""
    from vinecli.gis.prescription import read_prescription
    from vinecli.rows.segment_rates import segment_rates

    georef, rows, segments = field(work)
    t0 = time.perf_counter()
    m = read_prescription(path, georef, rows, column="rate", default_lpha=100.0)
    segment_rates(segments, rate_map=m.rates, prescription=m.summary(), rows=rows)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--zones", type=int, nargs="+", default=[2000, 20000, 100000])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--baseline-tree", type=Path, help="a checkout whose read_prescription is the baseline")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--read-once", nargs=2, help=argparse.SUPPRESS)  # PATH WORK: the subprocess of the baseline
    args = ap.parse_args(argv)
    if args.read_once:
        import vinecli

        print(json.dumps({"s": read_seconds(Path(args.read_once[0]), Path(args.read_once[1])),
                          "vinecli": vinecli.__file__}))
        return 0
    from vinecli.gis.prescription import read_prescription
    from vinecli.gis.zone_index import MAX_ZONES, ZoneIndex

    out: dict[str, Any] = {"zones": {}}
    with tempfile.TemporaryDirectory(prefix="vinecli-rx-") as tmp:
        work = Path(tmp)
        georef, rows, _ = field(work)
        x, y = stations(rows)
        for n in args.zones:
            path = write_grid(work / f"grid{n}.gpkg", georef, n)
            m = read_prescription(path, georef, rows, column="rate", default_lpha=100.0)
            t_scan, t_tree, t_read, t_base = [], [], [], []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                a = scan(m.zones, x, y)
                t_scan.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                b = ZoneIndex([z[0] for z in m.zones], [z[3] for z in m.zones]).first_zone(x, y)
                t_tree.append(time.perf_counter() - t0)
                assert (a == b).all(), "the STRtree and the scan disagree"
                t_read.append(read_seconds(path, work))
                if args.baseline_tree:
                    env = dict(os.environ, PYTHONPATH=str(args.baseline_tree.resolve()))
                    res = subprocess.run([sys.executable, __file__, "--read-once", str(path), str(work)], env=env,
                                         capture_output=True, text=True, check=True)
                    done = json.loads(res.stdout.splitlines()[-1])
                    assert done["vinecli"].startswith(str(args.baseline_tree.resolve())), done
                    t_base.append(done["s"])
            r = {"points": int(x.size), "scan_s": statistics.median(t_scan), "tree_s": statistics.median(t_tree),
                 "read_s": statistics.median(t_read)}
            r["scan_over_tree"] = r["scan_s"] / r["tree_s"]
            line = (f"{n:>7,} zones, {x.size:,} points: scan {r['scan_s']:.3f} s, STRtree {r['tree_s']:.4f} s "
                    f"({r['scan_over_tree']:.0f}x); read + segment rates {r['read_s']:.2f} s")
            if t_base:
                r["baseline_read_s"] = statistics.median(t_base)
                line += f", baseline tree {r['baseline_read_s']:.2f} s ({r['baseline_read_s'] / r['read_s']:.1f}x)"
            print(line, flush=True)
            out["zones"][n] = r
        big = write_grid(work / "too-many.gpkg", georef, MAX_ZONES + 1)
        t0 = time.perf_counter()
        try:
            read_prescription(big, georef, rows, column="rate", default_lpha=100.0)
            raise AssertionError("a map above MAX_ZONES was read")
        except Exception as exc:  # noqa: BLE001 - the refusal is an InputError
            out["refusal_s"] = time.perf_counter() - t0
            print(f"{MAX_ZONES + 1:,} zones refused in {out['refusal_s']:.3f} s: {exc}")
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
