"""What segment rates cost a run (target: a prescription adds < 10 % to the time of a run).

The missions of ``pipelines/dose.yaml`` (LWA dose, GeoPackage zones, ISO-XML grid on the sample vineyard, rows 1 and
5) against their uniform twin: the same mission with ``rate_lpha`` (the LWA run's mean rate: the same path, the
same litres), flown in the same process, interleaved (uniform, lwa, zones, grid, uniform, ...) so that the
machine's load moves them alike. Per run: the process CPU time of ``run_mission`` (set-up, loop, deposition,
as-applied evaluation and outputs) and the loop's CPU per physics step (summary.json ``timing.cpu_per_step_us``:
what following the rates costs in flight); the ratios of the medians against the uniform twin. A dosed run pays a fixed cost (reading the map, cutting the passes, the as-applied judgement and
its files) that a longer run spreads: ``--rows`` flies more rows (``--rows 1 5 9 13``: four passes).

    .venv/bin/python benchmarks/dose_speed.py [--repeats 5] [--rows 1 5] [--world DIR] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

REPO = Path(__file__).resolve().parents[1]
MISSIONS = REPO / "pipelines" / "missions" / "dose"


def _variant(work: Path, name: str, rows: list[int], rate_lpha: float | None = None) -> Path:
    """``pipelines/missions/dose/<name>.yaml`` over ``rows`` (its map's path absolute); with ``rate_lpha`` the
    uniform twin of the LWA mission."""
    doc = yaml.safe_load((MISSIONS / f"{name}.yaml").read_text())
    spray = doc["phases"][1]
    spray["rows"] = rows
    if spray.get("prescription"):
        spray["prescription"]["path"] = str((MISSIONS / spray["prescription"]["path"]).resolve())
    if rate_lpha is not None:
        for k in ("lwa_dose_l", "segment_m"):
            spray.pop(k)
        spray["rate_lpha"] = round(rate_lpha, 3)
        doc["name"] = "dose-uniform"
    doc["max_duration_s"] = 120 * len(rows) + 60
    path = work / f"{doc['name']}.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _fly(mission: Path, world: Path, out: Path) -> dict[str, Any]:
    from vinecli.runs.mission import run_mission
    from vinecli.runs.request import RunRequest

    c0, w0 = time.process_time(), time.perf_counter()
    s = run_mission(RunRequest(mission, world, out, overwrite=True))
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    summary = json.loads((Path(s.run_dir) / "summary.json").read_text())
    return {"cpu_s": cpu, "wall_s": wall, "step_us": summary["timing"]["cpu_per_step_us"], "passed": s.passed,
            "in_band": (summary.get("as_applied") or {}).get("in_band_fraction")}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--rows", type=int, nargs="+", default=[1, 5], help="the world's rows the missions spray")
    ap.add_argument("--world", type=Path, default=None, help="a built worlds/vineyard-sample.yaml (default: build it)")
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="vinecli-dose-speed-") as tmp:
        work = Path(tmp)
        world = a.world
        if world is None:
            from vinecli.world import build_world

            world = build_world(REPO / "worlds" / "vineyard-sample.yaml", work / "world")
        from vinecli.missions.spec_io import read_mission
        from vinecli.sim.dose_setup import resolve_dose_phases
        from vinecli.world import load_world

        cases = {name: _variant(work, name, a.rows) for name in ("lwa", "zones", "grid")}
        _fly(cases["lwa"], world, work / "warm")  # warm-up: imports, caches
        flown, _ = resolve_dose_phases(read_mission(cases["lwa"]).spec, load_world(world))
        rate = float(flown.phases[1].rate_lpha)  # the LWA run's mean rate: the uniform twin's
        cases = {"uniform": _variant(work, "lwa", a.rows, rate), **cases}
        res: dict[str, list[dict[str, Any]]] = {k: [] for k in cases}
        for i in range(a.repeats):
            for name, mission in cases.items():
                res[name].append(_fly(mission, world, work / "runs"))
                r = res[name][-1]
                print(f"repeat {i + 1} {name:8s} cpu {r['cpu_s']:6.2f} s  wall {r['wall_s']:6.2f} s  passed {r['passed']}",
                      flush=True)
    med = {k: {m: statistics.median(r[m] for r in v) for m in ("cpu_s", "wall_s", "step_us")} for k, v in res.items()}
    print(f"rows {a.rows}, uniform twin at {rate:.2f} L/ha; medians of {a.repeats} interleaved repeats:")
    for k, m in med.items():
        print(f"  {k:8s} cpu {m['cpu_s']:6.2f} s ({m['cpu_s'] / med['uniform']['cpu_s']:.3f}x)  "
              f"wall {m['wall_s']:6.2f} s ({m['wall_s'] / med['uniform']['wall_s']:.3f}x)  "
              f"loop {m['step_us']:5.1f} µs/step ({m['step_us'] / med['uniform']['step_us']:.3f}x)")
    if a.json:
        a.json.write_text(json.dumps({"rows": a.rows, "rate_lpha": rate, "runs": res, "medians": med}, indent=1) + "\n")
    worst = max(med[k]["cpu_s"] / med["uniform"]["cpu_s"] for k in ("lwa", "zones", "grid"))
    return 0 if worst < 1.10 else 1


if __name__ == "__main__":
    sys.exit(main())
