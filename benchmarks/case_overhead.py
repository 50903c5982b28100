"""What a batch worker pays per case besides the loop, against another checkout in the same run.

A worker process runs the same mission ``--cases`` times in a row (``run_mission`` of a ``RunRequest``, as
``vinecli.batch.case.run_one`` does), with what a worker keeps between cases (``reuse_terrain_engines()``: the
engine and its terrain; on this branch also the parked vehicle and the loaded world; the mission handed in read
once, a ``MissionFile``, as this branch's batch hands it) and without it (a fresh engine, terrain and world per
case, the mission file read per case). Per case: the whole ``run_mission`` time minus the loop's (``summary.json``
``timing``), in process CPU time (what a loaded machine moves least; wall time too) is the overhead: reading the
mission, loading the world, the set-up, the engine, the checks and writing the run directory. The first case of each process is not counted (imports, bytecode); the median of the rest is. Each configuration
runs in its own process, the checkouts interleaved round by round, best of ``--rounds`` (by the overhead's CPU).

    .venv/bin/python benchmarks/case_overhead.py [--baseline OTHER_CHECKOUT] [--mission takeoff] [--cases 6]
        [--rounds 3] [--json F]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, sys, time
from pathlib import Path
sys.path.insert(0, sys.argv[1])
from vinecli.missions.spec_io import read_mission
from vinecli.runs.mission import run_mission
from vinecli.runs.request import RunRequest
from vinecli.world.engine import reuse_terrain_engines
world, mission, n, keep, runs = Path(sys.argv[2]), Path(sys.argv[3]), int(sys.argv[4]), sys.argv[5] == "1", Path(sys.argv[6])
reuse_terrain_engines(keep)
out = []
given = read_mission(mission) if keep else mission
for i in range(n):
    t, c = time.perf_counter(), time.process_time()
    s = run_mission(RunRequest(given, world, runs, seed=0, run_id=f"c{i}", overwrite=True))
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    tm = json.loads((Path(s.run_dir) / "summary.json").read_text())["timing"]
    out.append([wall, tm["loop_wall_s"], cpu, tm["loop_wall_s"] * tm["cpu_per_step_us"] / tm["wall_per_step_us"]])
print(json.dumps(out))
"""


def _env(checkout: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(PYTHONPATH=str(checkout), OPENBLAS_NUM_THREADS="1")
    return env


def build_world(checkout: Path, out: Path) -> Path:
    if not (out / "world.json").is_file():
        subprocess.run([sys.executable, "-m", "vinecli", "world", "build", str(checkout / "worlds" / "vineyard-sample.yaml"),
                        "--out", str(out)], cwd=checkout, env=_env(checkout), check=True, capture_output=True)
    return out


def overhead(checkout: Path, world: Path, mission: str, cases: int, keep: bool, runs: Path) -> dict[str, float]:
    """Median per-case overhead (s) and loop (s) of one worker process, the first case left out."""
    res = subprocess.run([sys.executable, "-c", CHILD, str(checkout), str(world),
                          str(checkout / "pipelines" / "missions" / f"{mission}.yaml"), str(cases), "1" if keep else "0",
                          str(runs)], cwd=checkout, env=_env(checkout), capture_output=True, text=True, check=True)
    rows = json.loads(res.stdout.strip().splitlines()[-1])[1:]
    return {"overhead_s": statistics.median(w - lp for w, lp, _, _ in rows),
            "loop_s": statistics.median(lp for _, lp, _, _ in rows),
            "overhead_cpu_s": statistics.median(c - lc for _, _, c, lc in rows),
            "loop_cpu_s": statistics.median(lc for _, _, _, lc in rows)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", type=Path, help="another checkout (same Python environment)")
    ap.add_argument("--mission", default="takeoff", help="a mission of pipelines/missions/")
    ap.add_argument("--cases", type=int, default=6, help="cases per worker process (the first is not counted)")
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds (best of)")
    ap.add_argument("--json", type=Path, help="write the figures as JSON")
    args = ap.parse_args(argv)
    checkouts = {"this": REPO}
    if args.baseline is not None:
        checkouts["baseline"] = args.baseline.resolve()
    best: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory(prefix="vinecli-case-") as tmp_s:
        tmp = Path(tmp_s)
        worlds = {k: build_world(c, tmp / f"world-{k}") for k, c in checkouts.items()}
        for _ in range(args.rounds):
            for keep in (True, False):
                for k, c in checkouts.items():
                    name = f"{k} {'kept' if keep else 'fresh'}"
                    r = overhead(c, worlds[k], args.mission, args.cases, keep, tmp / f"runs-{k}")
                    if name not in best or r["overhead_cpu_s"] < best[name]["overhead_cpu_s"]:
                        best[name] = r
    print(f"{args.mission}: per case in a worker process, median of {args.cases - 1} cases, best of {args.rounds} rounds")
    for name, r in best.items():
        print(f"  {name:16s} overhead CPU {r['overhead_cpu_s'] * 1e3:7.1f} ms, wall {r['overhead_s'] * 1e3:7.1f} ms"
              f" (loop CPU {r['loop_cpu_s'] * 1e3:7.1f} ms, wall {r['loop_s'] * 1e3:7.1f} ms)")
    res: dict[str, Any] = {"mission": args.mission, "cases": best}
    if "baseline" in checkouts:
        for keep in ("kept", "fresh"):
            ratio = best[f"this {keep}"]["overhead_cpu_s"] / best[f"baseline {keep}"]["overhead_cpu_s"]
            res[f"{keep}_overhead_cpu_this_over_baseline"] = ratio
            print(f"  {keep}, overhead CPU this / baseline: {ratio:.2f}x")
    if args.json:
        args.json.write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
