"""Firmware verdicts under load: ``pipelines/ci-ardupilot.yaml`` and ``pipelines/ci-px4.yaml`` over seeds
0..N-1, once as the machine is and once beside a CPU hog (``--hog`` x CPU-count busy processes, default 2x);
prints per pipeline the passes of each pass, the cases whose verdict differs, the lockstep stalls, the worst
dose of the spray cases (row mean error, 1 m hot spot and gap ratios) and how many trajectories are
bit-identical between the two passes (ArduPilot's lockstep makes them so; PX4's
mission link is its own threads, so its trajectories may shift while the verdicts stay). Every wait on a
firmware is the lockstep or simulated time: a verdict must not depend on the load.

    .venv/bin/python benchmarks/firmware_load.py --ardupilot-bin AP/bin/arducopter --px4-bin PX4/bin/px4 \\
        [--seeds 10] [--first-seed 0] [--workers 2] [--hog 2] [--pipelines ci-ardupilot ci-px4] [--json out.json]
        [--keep DIR]

``--hog 0`` flies one pass only (a seed sweep: pass counts, stalls, dose).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
DOSE = ("row_rate_ratio_min", "row_rate_ratio_max", "dose_window_ratio_min", "dose_window_ratio_max",
        "row_coverage_fraction")
HOG = "import time\nwhile True:\n    sum(i * i for i in range(10000))\n"


def _pipeline(name: str, n_seeds: int, work: Path, first: int = 0) -> Path:
    """``pipelines/<name>.yaml`` with each mission replicated over seeds first..first+n-1 on a world built once."""
    from vinecli.batch.pipeline import load_pipeline
    from vinecli.batch.run import build_world_once

    src = REPO / "pipelines" / f"{name}.yaml"
    spec = load_pipeline(src)
    assert spec.world is not None
    world = build_world_once((src.parent / spec.world).resolve(), work / "_worlds")
    pipe = work / f"load-{name}.yaml"
    pipe.write_text(json.dumps({
        "name": f"load-{name}", "world": str(world), "seed": 0, "timeout_s": 1200, "autopilot": spec.autopilot,
        "missions": [{"mission": str((src.parent / e.mission).resolve()), "seed": first, "seeds": n_seeds}
                     for e in spec.missions]}))
    return pipe


def _trajectory_hash(run: Path) -> str | None:
    from vinecli.runs.rundir import read_timeseries

    f = run / "timeseries.parquet"
    if not f.is_file():
        return None
    ts = read_timeseries(f)
    h = hashlib.sha256()
    for col in ("t_s", "pos_enu_x_m", "pos_enu_y_m", "pos_enu_z_m", "rotor1_cmd_radps", "tank_flow_lps"):
        if col in ts:
            h.update(ts[col].tobytes())
    return h.hexdigest()


def _pass(pipe: Path, out: Path, workers: int, bins: dict[str, str]) -> dict[str, dict[str, Any]]:
    from vinecli.batch import run_batch

    t0 = time.perf_counter()
    res = run_batch(pipe, out, workers=workers, **bins)
    if res.signum is not None:  # SIGTERM / SIGINT: the batch wrote its partial runs; no verdicts to compare
        raise SystemExit(128 + res.signum)
    cases = {}
    for c in res.cases:
        s = json.loads((out / c.run_id / "summary.json").read_text()) if (out / c.run_id / "summary.json").is_file() else {}
        m = s.get("metrics") or {}
        cases[c.case] = {"passed": c.passed, "status": c.status, "error": c.error,
                         "stalls": m.get("px4_stalls", m.get("ardupilot_stalls")),
                         "battery_warnings": m.get("px4_battery_warnings", m.get("ardupilot_battery_warnings")),
                         "failed": c.failed_checks, "trajectory": _trajectory_hash(out / c.run_id),
                         "dose": {k: m[k] for k in DOSE if k in m}}
    print(f"  {out.name}: {sum(c['passed'] for c in cases.values())}/{len(cases)} passed in "
          f"{time.perf_counter() - t0:.0f} s", flush=True)
    return cases


def _worst_dose(passes: list[dict[str, dict[str, Any]]]) -> dict[str, float]:
    """The worst of each dose figure over the spray cases of all passes."""
    out: dict[str, float] = {}
    for cases in passes:
        for c in cases.values():
            for k, v in (c.get("dose") or {}).items():
                if v is None:
                    continue
                worse = max if k in ("row_rate_ratio_max", "dose_window_ratio_max") else min
                out[k] = worse(out.get(k, v), v)
    return out


def run(name: str, n_seeds: int, workers: int, hog: float, work: Path, bins: dict[str, str], first: int = 0
        ) -> dict[str, Any]:
    """Both passes of one pipeline (one without ``hog``) and their comparison."""
    pipe = _pipeline(name, n_seeds, work, first)
    print(f"{name}: seeds {first}-{first + n_seeds - 1}", flush=True)
    quiet = _pass(pipe, work / f"{name}-as-is", workers, bins)
    n_hog = max(1, round(hog * (os.cpu_count() or 1))) if hog > 0 else 0
    loaded: dict[str, dict[str, Any]] = {}
    if n_hog:
        hogs = [subprocess.Popen([sys.executable, "-c", HOG]) for _ in range(n_hog)]
        try:
            loaded = _pass(pipe, work / f"{name}-hog", workers, bins)
        finally:
            for p in hogs:
                p.kill()
            for p in hogs:
                p.wait()
    differ = sorted(c for c in quiet if n_hog and (quiet[c]["passed"], quiet[c]["status"]) !=
                    (loaded.get(c, {}).get("passed"), loaded.get(c, {}).get("status")))
    same_traj = sum(1 for c in quiet if quiet[c]["trajectory"] and quiet[c]["trajectory"] == loaded.get(c, {}).get("trajectory"))
    return {"pipeline": name, "seeds": [first, first + n_seeds - 1], "cases": len(quiet), "hog_processes": n_hog,
            "passed_as_is": sum(c["passed"] for c in quiet.values()),
            "passed_beside_hog": sum(c["passed"] for c in loaded.values()) if n_hog else None,
            "verdicts_differ": differ, "identical_trajectories": same_traj,
            "stalls": sum(int(c["stalls"] or 0) for c in [*quiet.values(), *loaded.values()]),
            "battery_warnings": sum(int(c["battery_warnings"] or 0) for c in [*quiet.values(), *loaded.values()]),
            "worst_dose": _worst_dose([quiet, loaded]),
            "failures": [[k, c, v["status"], v["failed"], v["error"]] for k, d in (("as-is", quiet), ("hog", loaded))
                         for c, v in d.items() if not v["passed"]]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pipelines", nargs="+", default=["ci-ardupilot", "ci-px4"])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--hog", type=float, default=2.0, help="busy processes per CPU beside the second pass (0: one pass)")
    ap.add_argument("--px4-bin")
    ap.add_argument("--ardupilot-bin")
    ap.add_argument("--json")
    ap.add_argument("--keep", help="keep the runs in this directory")
    a = ap.parse_args()
    bins = {k: v for k, v in (("px4_bin", a.px4_bin), ("ardupilot_bin", a.ardupilot_bin)) if v}
    work = Path(a.keep) if a.keep else Path(tempfile.mkdtemp(prefix="vinecli-load-"))
    work.mkdir(parents=True, exist_ok=True)
    results = [run(p, a.seeds, a.workers, a.hog, work, bins, a.first_seed) for p in a.pipelines]
    for r in results:
        hogged = (f"{r['passed_beside_hog']}/{r['cases']} beside {r['hog_processes']} busy processes; verdicts differ: "
                  f"{r['verdicts_differ'] or 'none'}; bit-identical trajectories {r['identical_trajectories']}/{r['cases']}; "
                  if r["hog_processes"] else "")
        print(f"{r['pipeline']} seeds {r['seeds'][0]}-{r['seeds'][1]}: {r['passed_as_is']}/{r['cases']} passed as is, "
              f"{hogged}stalls {r['stalls']}; battery warnings {r['battery_warnings']}; worst dose {r['worst_dose']}")
        for f in r["failures"]:
            print(f"    {f}")
    if a.json:
        Path(a.json).write_text(json.dumps(results, indent=1))
    return 0 if all(not r["verdicts_differ"] for r in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
