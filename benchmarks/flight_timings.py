"""Take-off and landing timings of kept run directories (e.g. ``benchmarks/seeds.py --keep DIR``),
per mission over its seeds: median and maximum of

* ``arm_to_liftoff_s``: first arming -> the simulator's first ``liftoff`` event (ground truth);
* ``takeoff_s``: take-off phase start -> its end (the altitude reached);
* ``landing_s``: each land phase start -> its end (descent, touchdown and land detection);
* ``land_detect_delay_s``: each truth ``touchdown`` -> the autopilot's next ``land_detected``
  (how long the land detector needs, per landing);
* ``touchdown_speed_mps``: vertical speed (ground truth, down positive) in the last recorded row
  before each truth touchdown;
* ``max_impact_speed_mps``: the simulator's metric (largest vertical speed at a first contact).

    .venv/bin/python benchmarks/flight_timings.py RUNS_DIR [RUNS_DIR ...] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from vinecli.runs.rundir import EVENTS, SUMMARY, TIMESERIES, read_events, read_timeseries  # noqa: E402


def run_timings(run_dir: Path) -> dict[str, list[float]]:
    """The timings of one run directory (lists: a run may land several times)."""
    summary = json.loads((run_dir / SUMMARY).read_text())
    events = read_events(run_dir / EVENTS)
    out: dict[str, list[float]] = defaultdict(list)
    arm = next((e["t_s"] for e in events if e["kind"] == "arming" and e["data"].get("armed")), None)
    lift = next((e["t_s"] for e in events if e["kind"] == "liftoff"), None)
    if arm is not None and lift is not None:
        out["arm_to_liftoff_s"].append(lift - arm)
    start = next((e["t_s"] for e in events if e["kind"] == "phase" and e["data"].get("type") == "takeoff"
                  and e["data"].get("event") == "start"), None)
    end = next((e["t_s"] for e in events if e["kind"] == "phase" and e["data"].get("type") == "takeoff"
                and e["data"].get("event") == "end"), None)
    if start is not None and end is not None:
        out["takeoff_s"].append(end - start)
    land_start: dict[object, float] = {}
    for e in events:
        if e["kind"] == "phase" and e["data"].get("type") == "land":
            if e["data"].get("event") == "start":
                land_start[e["data"].get("index")] = e["t_s"]
            elif e["data"].get("index") in land_start:
                out["landing_s"].append(e["t_s"] - land_start.pop(e["data"].get("index")))
    detected = [e["t_s"] for e in events if e["kind"] == "land_detected"]
    touchdowns = [e["t_s"] for e in events if e["kind"] == "touchdown"]
    for td in touchdowns:
        after = [t for t in detected if t >= td]
        if after:
            out["land_detect_delay_s"].append(after[0] - td)
    if touchdowns:
        ts = read_timeseries(run_dir / TIMESERIES)
        t, vz = ts["t_s"], ts["vel_enu_z_mps"]
        for td in touchdowns:
            i = int((t < td).sum()) - 1
            if i >= 0:
                out["touchdown_speed_mps"].append(float(-vz[i]))
    imp = (summary.get("metrics") or {}).get("max_impact_speed_mps")
    if imp is not None:
        out["max_impact_speed_mps"].append(float(imp))
    return out


def collect(roots: list[Path]) -> dict[str, dict[str, list[float]]]:
    """Timings per mission (summary ``mission``) over every run directory under ``roots``."""
    per: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for root in roots:
        for summ in sorted(root.rglob(SUMMARY)):
            mission = json.loads(summ.read_text()).get("mission", summ.parent.name)
            for k, v in run_timings(summ.parent).items():
                per[mission][k].extend(v)
    return per


def table(per: dict[str, dict[str, list[float]]]) -> dict[str, dict[str, dict[str, float]]]:
    """n, median and max of each timing per mission."""
    return {m: {k: {"n": len(v), "median": round(statistics.median(v), 3), "max": round(max(v), 3)}
                for k, v in sorted(d.items()) if v} for m, d in sorted(per.items())}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("roots", nargs="+", type=Path)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    res = table(collect(args.roots))
    for mission, d in res.items():
        print(mission)
        for k, s in d.items():
            print(f"  {k:24s} n={s['n']:4d}  median {s['median']:8.3f}  max {s['max']:8.3f}")
    if args.json is not None:
        args.json.write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
