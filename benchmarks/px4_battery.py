"""PX4's periodic work over many real PX4 runs: one mission (default the CI take-off) flown by real PX4 SITL
over seeds, one PX4 at a time; after each run PX4's own kept ULog is audited (vinecli.sitl.px4.log_audit):
did ``battery_status`` (battery_simulator) and ``cpuload`` (load_mon) run to the end of the log, and did PX4
warn "Battery unhealthy"? Prints one line per run and the counts: the flake (PX4 v1.15's HRT race
at arming, see vinecli/sitl/px4/process.py SAFE_BOOT_PARAMS) is a stopped topic.

    .venv/bin/python benchmarks/px4_battery.py --px4-bin PX4/bin/px4 --world build/vineyard [--seeds 40]
        [--first-seed 0] [--mission pipelines/missions/takeoff.yaml] [--out DIR]

``--px4-bin`` may be a wrapper script beside an ``etc`` directory (e.g. one that drops CAP_SYS_NICE and pins
PX4 to one CPU, as PX4 runs for a user without real-time priorities: the race is more frequent there).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def one_run(mission: Path, world: Path, out: Path, seed: int, px4_bin: str) -> dict[str, object]:
    """Fly ``mission`` with PX4 at ``seed`` and audit PX4's kept log."""
    import json

    from vinecli.errors import VinecliError
    from vinecli.runs import RunRequest, run_mission
    from vinecli.sitl.options import AutopilotOptions
    from vinecli.sitl.px4.log_audit import audit_ulog

    t0 = time.perf_counter()
    try:
        run_mission(RunRequest(mission, world, out, seed=seed, autopilot="px4", run_id=f"s{seed}",
                               autopilot_options=AutopilotOptions(px4_bin=px4_bin)))
    except VinecliError as exc:
        return {"seed": seed, "error": str(exc)}
    summary = json.loads((out / f"s{seed}" / "summary.json").read_text())
    ulg = next((out / f"s{seed}" / "firmware").glob("*.ulg"))
    audit = audit_ulog(ulg)
    return {"seed": seed, "wall_s": round(time.perf_counter() - t0, 1), "status": summary["status"],
            "stopped": {s.topic: round(s.last_s, 2) for s in audit.stops},
            "unhealthy": len(audit.stale_battery_warnings),
            "px4_battery_warnings": summary["metrics"].get("px4_battery_warnings"),
            "px4_scheduler_faults": summary["metrics"].get("px4_scheduler_faults")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--px4-bin", required=True)
    ap.add_argument("--world", required=True, type=Path, help="a built world (vinecli world build)")
    ap.add_argument("--mission", type=Path, default=REPO / "pipelines" / "missions" / "takeoff.yaml")
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=None, help="keep the runs here (default: a temporary directory)")
    args = ap.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="px4-battery-"))
    rows = []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        r = one_run(args.mission, args.world, out, seed, args.px4_bin)
        rows.append(r)
        print(r, flush=True)
    done = [r for r in rows if "error" not in r]
    batt = sum("battery_status" in r["stopped"] for r in done)  # type: ignore[operator]
    cpu = sum("cpuload" in r["stopped"] for r in done)  # type: ignore[operator]
    print(f"{len(done)} PX4 runs ({len(rows) - len(done)} errors): battery_status stopped in {batt}, cpuload stopped "
          f"in {cpu}, any periodic topic stopped in {sum(bool(r['stopped']) for r in done)}, 'Battery unhealthy' "
          f"from a stopped battery_status in {sum(bool(r['unhealthy']) for r in done)}; runs in {out}")


if __name__ == "__main__":
    main()
