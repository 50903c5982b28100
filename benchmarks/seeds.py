"""Seed sweep of the CI gate: every mission of ``pipelines/ci.yaml`` and ``pipelines/ci-hills.yaml``
over seeds 0..N-1 (sensor noise, turbulence); prints the failures per mission. Target: 0 of 100.

The pipeline's world is built once (not timed); each mission runs as one batch entry with
``seed: 0, seeds: N`` (seeds 0, 1, ..., N-1) on the local process pool. Too slow for the test
suite (800 runs, ~15 min on 2 cores); ``tests/batch/test_seed_sweep.py`` runs a handful of seeds.

    .venv/bin/python benchmarks/seeds.py [--quick] [--seeds 100] [--workers 2] [--pipelines ci ci-hills]
                                         [--missions takeoff spray ...] [--json out.json] [--keep RUNS_DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]


def sweep(pipeline: Path, n_seeds: int, workers: int, work: Path, only: Sequence[str] = ()) -> dict[str, Any]:
    """Run every mission of ``pipeline`` (or those named in ``only``) for seeds 0..n_seeds-1 under ``work``;
    failures per mission."""
    from vinecli.batch import run_batch
    from vinecli.batch.pipeline import load_pipeline
    from vinecli.batch.run import build_world_once

    ci = load_pipeline(pipeline)
    assert ci.world is not None
    world = build_world_once((pipeline.parent / ci.world).resolve(), work / "_worlds")
    missions = [str((pipeline.parent / e.mission).resolve()) for e in ci.missions
                if not only or Path(str(e.mission)).stem in only]
    pipe = work / f"seeds-{ci.name}.yaml"
    pipe.write_text(json.dumps({
        "name": f"seeds-{ci.name}", "world": str(world), "seed": 0, "timeout_s": 900,
        "missions": [{"mission": m, "seed": 0, "seeds": n_seeds} for m in missions],
    }))
    t0 = time.perf_counter()
    res = run_batch(pipe, work / f"runs-{ci.name}", workers=workers)
    wall = time.perf_counter() - t0
    per: dict[str, dict[str, Any]] = {}
    for c in res.cases:
        mission = c.case.rsplit("-s", 1)[0]
        m = per.setdefault(mission, {"runs": 0, "failed": 0, "failures": []})
        m["runs"] += 1
        if not c.passed:
            m["failed"] += 1
            msg = c.error or ""
            summary = work / f"runs-{ci.name}" / c.run_id / "summary.json"
            if summary.is_file():
                msg = json.loads(summary.read_text()).get("status_message") or msg
            m["failures"].append({"seed": c.seed, "status": c.status, "failed_checks": c.failed_checks,
                                  "message": msg})
    return {"pipeline": ci.name, "seeds": n_seeds, "wall_s": round(wall, 1), "missions": per}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="smoke run: 3 seeds")
    ap.add_argument("--seeds", type=int, default=100, help="seeds 0..N-1 per mission")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--pipelines", nargs="+", default=["ci", "ci-hills"], help="names in pipelines/")
    ap.add_argument("--missions", nargs="+", default=[], help="only these missions (file stems), default all")
    ap.add_argument("--json", type=Path, default=None, help="also write the results as JSON")
    ap.add_argument("--keep", type=Path, default=None, help="keep the run directories here (default: a temp dir)")
    args = ap.parse_args()
    n = 3 if args.quick else args.seeds
    results: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="vinecli-seeds-") as tmp_s:
        work = args.keep or Path(tmp_s)
        work.mkdir(parents=True, exist_ok=True)
        for name in args.pipelines:
            r = sweep(REPO / "pipelines" / f"{name}.yaml", n, args.workers, work, args.missions)
            results.append(r)
            for mission, m in r["missions"].items():
                print(f"{r['pipeline']:9s} {mission:9s} {m['failed']} of {m['runs']} failed")
                for f in m["failures"]:
                    print(f"    seed {f['seed']}: {f['status']}; failed {', '.join(f['failed_checks'])}; {f['message']}")
            print(f"{r['pipeline']}: {r['wall_s']:.0f} s wall")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n")
    return 1 if any(m["failed"] for r in results for m in r["missions"].values()) else 0


if __name__ == "__main__":
    sys.exit(main())
