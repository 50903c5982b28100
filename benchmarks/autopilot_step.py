"""Per-step cost of the built-in autopilot (µs per ``step``), without PyBullet.

Records the observations of a simulated flight (takeoff, hold, goto, land) of the
pure-Python rigid-body double from tests/autopilot, then times a fresh autopilot replaying
them, with the estimator and with ``truth=True``. ``--quick`` for a smoke run.

    .venv/bin/python benchmarks/autopilot_step.py [--quick] [--vehicle x500]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))


def main() -> None:
    from autopilot.rigid_body import RigidBodyDouble  # tests/autopilot

    from vinecli.autopilot.builtin import BuiltinAutopilot
    from vinecli.specs import load_spec
    from vinecli.specs.mission import MissionSpec
    from vinecli.specs.vehicle import VehicleSpec

    ap_ = argparse.ArgumentParser(description=__doc__)
    ap_.add_argument("--quick", action="store_true", help="short flight, one repetition")
    ap_.add_argument("--vehicle", default="x500")
    args = ap_.parse_args()
    v = load_spec(REPO / "vehicles" / f"{args.vehicle}.yaml", VehicleSpec)
    phases = [{"type": "takeoff", "altitude_agl_m": 4.0}, {"type": "hold", "duration_s": 2.0 if args.quick else 10.0},
              {"type": "goto", "position_enu": [8.0, 4.0]}, {"type": "land"}]
    reps = 1 if args.quick else 5
    for truth in (False, True):
        m = MissionSpec(name="bench", truth=truth, phases=phases)
        d = RigidBodyDouble(v)
        rec = BuiltinAutopilot()
        rec.reset(d.context(m))
        obs = []
        for _ in range(int((10 if args.quick else 40) / d.dt)):
            o = d.observe()
            obs.append(o)
            cmd = rec.step(o)
            if rec.status().done:
                break
            d.advance(cmd.rotor_speed_cmd, cmd.spray_flow_lps)
        per_step = []
        for _ in range(reps):
            ap = BuiltinAutopilot()
            ap.reset(d.context(m))
            step = ap.step
            t0 = time.perf_counter()
            for o in obs:
                step(o)
            per_step.append((time.perf_counter() - t0) / len(obs) * 1e6)
        label = "truth" if truth else "estimator"
        print(f"{args.vehicle:14s} {label:9s} {len(obs):6d} steps  min {min(per_step):5.1f} µs  "
              f"median {statistics.median(per_step):5.1f} µs per step")


if __name__ == "__main__":
    main()
