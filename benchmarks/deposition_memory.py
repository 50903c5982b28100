"""Peak memory (RSS) of a whole spraying run against the spray height, with the same run unsprayed as baseline.

Each case is one ``vinecli run mission`` in a fresh process on a flat world with nine rows under a BBCH 75
canopy, so the spray budget runs with its canopy maps (the mission's own 180 m fence with a 1 km ceiling):
take off to the spray height, spray one 20 m row at ``height_agl_m`` = H (flow 0.02 L/s), land. The peak resident set of
that process (``wait4``'s ``ru_maxrss``) is compared with the same flight along the row without the
sprayer (a waypoints phase: no deposition), run right after it: the difference is what the deposition
model (records, transport, grid, writing deposition.tif) adds at that height. No accepted
mission peaks above 1.5 GB; the deposition grid keeps its convolution inside a cell budget
(:mod:`vinecli.spray.deposit_grid`), so the peak must not grow with the height.

Usage::

    python benchmarks/deposition_memory.py                    # heights 2 10 50 100 200 400 m
    python benchmarks/deposition_memory.py --heights 2 400 --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LIMIT_MB = 1536.0

MISSION = """\
name: {name}
vehicle: x500-sprayer
tank_fill_l: 1.0
max_duration_s: {duration}
record_rate_hz: 10
geofence: {{polygon_enu: [[-90, -90], [90, -90], [90, 90], [-90, 90]], max_altitude_agl_m: 1000}}
phases:
  - {{type: takeoff, altitude_agl_m: {height}, timeout_s: {duration}}}
  - {fly}
  - {{type: land, timeout_s: {duration}}}
"""
#: flat ground with nine 60 m rows 2.5 m apart under a BBCH 75 canopy: the spray budget runs with its canopy maps
WORLD = """\
name: canopy-flat
terrain: {type: flat, z_m: 0.0, size_m: 200.0}
origin: {lat: 47.397742, lon: 8.545594, alt: 488.0}
vehicle: x500-sprayer
rows: [""" + ", ".join(f"[[-20, {y}], [40, {y}]]" for y in (-10.0, -7.5, -5.0, -2.5, 0.0, 2.5, 5.0, 7.5, 10.0)) + """]
canopy: {bbch: 75}
"""
SPRAY = "{{type: spray, rows: [[[0.0, 0.0], [20.0, 0.0]]], height_agl_m: {height}, speed_mps: 3.0, flow_lps: 0.02}}"
DRY = "{{type: waypoints, waypoints: [[0.0, 0.0, {height}], [20.0, 0.0, {height}]], speed_mps: 3.0}}"


def _vinecli() -> str:
    exe = Path(sys.executable).with_name("vinecli")
    return str(exe) if exe.exists() else "vinecli"


def peak_rss_mb(args: list[str], cwd: Path) -> tuple[float, int, float]:
    """(peak RSS of the child process in MB, its exit code, wall s)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(args, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _pid, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode(errors="replace").strip().splitlines() if proc.stderr else []
    if proc.returncode not in (0, 1):
        print(f"    exit {proc.returncode}: {err[-1] if err else ''}")
    return usage.ru_maxrss / 1024.0, proc.returncode, time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--heights", type=float, nargs="+", default=[2.0, 10.0, 50.0, 100.0, 200.0, 400.0])
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    exe = _vinecli()
    rows = []
    with tempfile.TemporaryDirectory(prefix="vinecli-depmem-") as tmp:
        work = Path(tmp)
        (work / "world.yaml").write_text(WORLD)
        subprocess.run([exe, "world", "build", "world.yaml", "--out", "world"], cwd=work, check=True,
                       stdout=subprocess.DEVNULL)
        for h in args.heights:
            duration = 60.0 + 2.0 * h  # climb (~3 m/s up), the row, the descent
            res = {}
            for label, fly in (("spray", SPRAY), ("dry", DRY)):
                name = f"h{int(h)}-{label}"
                (work / f"{name}.yaml").write_text(MISSION.format(name=name, height=h, duration=duration,
                                                                  fly=fly.format(height=h)))
                res[label] = peak_rss_mb([exe, "run", "mission", f"{name}.yaml", "--world", "world", "--out", "runs"],
                                         work)
            (mb, rc, wall), (base, _rc, _w) = res["spray"], res["dry"]
            dep = work / "runs" / f"h{int(h)}-spray-s0" / "deposition.json"
            cell = json.loads(dep.read_text())["grid"]["cell_m"] if dep.is_file() else None
            rows.append({"height_m": h, "peak_rss_mb": round(mb, 1), "dry_peak_rss_mb": round(base, 1),
                         "deposition_mb": round(mb - base, 1), "ratio": round(mb / base, 3), "exit": rc,
                         "wall_s": round(wall, 1), "cell_m": cell})
            r = rows[-1]
            print(f"h = {h:6.1f} m: peak {r['peak_rss_mb']:7.1f} MB (sprayer off {r['dry_peak_rss_mb']:7.1f} MB, "
                  f"x{r['ratio']:.2f}, +{r['deposition_mb']:.1f} MB), cell {cell} m, exit {rc}, {r['wall_s']} s",
                  flush=True)
    worst = max(r["peak_rss_mb"] for r in rows)
    print(f"largest peak {worst:.0f} MB, limit {LIMIT_MB:.0f} MB: {'ok' if worst <= LIMIT_MB else 'OVER'}")
    if args.json is not None:
        args.json.write_text(json.dumps({"limit_mb": LIMIT_MB, "runs": rows}, indent=2) + "\n")
    return 0 if worst <= LIMIT_MB else 1


if __name__ == "__main__":
    sys.exit(main())
