"""How real a fitted vehicle is: ``vinecli vehicle fit`` on the real flight logs of ../shared and on the
known-truth simulated flight, each replayed against its baselines (the log's mean, the unfitted base).

Usage: ``python benchmarks/fit_logs.py [--base x500] [--no-truth] [--mass KG]``

Prints per log: the hover throttle against the log's own steady hover, the energy of the flight (the
model against ``integral V I dt``, in-sample and held out), the fitted parameters with their std and source,
and the replay errors next to the baselines'. ``--no-truth`` skips the simulated flight (tests/identify).
The real logs are read from ../shared/data/flightlogs (no licence: never copied into the repository).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
LOGS = REPO.parent / "shared" / "data" / "flightlogs"
SHOWN = ("hover_throttle", "thrust_curve_offset_r", "thrust_to_weight", "k_f", "body_drag_kg_per_m", "k_d",
         "wind_east_mps", "wind_north_mps", "pack_resistance_ohm", "capacity_wh", "motor_efficiency", "k_m",
         "avionics_w", "hover_power_w", "overall_figure_of_merit")


def _fmt(v: Any) -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.4g}"


def report(name: str, r: Any, seconds: float) -> None:
    rep = r.report
    hc, en = rep["hover_check"], rep["energy"] or {}
    print(f"\n## {name}  ({r.log.info.firmware}; fit + replay {seconds:.1f} s)")
    print(f"hover throttle {rep['hover_throttle']:.4f} ± {rep['hover_throttle_std']:.4f} ({rep['hover_pwm_us']:.0f} us); "
          f"log's steady hover {hc.get('log_hover_output', math.nan):.4f} over {hc.get('samples')} samples: "
          f"{100 * hc.get('error_fraction', math.nan):+.2f} %")
    if en:
        held = ", ".join(f"{100 * x:+.1f} %" for x in en["held_out_error_fractions"])
        print(f"energy: log {en['log_wh']:.3f} Wh, model {en['model_wh']:.3f} Wh: {100 * en['error_fraction']:+.2f} % "
              f"(held out: {held})")
    for k in SHOWN:
        p = rep["parameters"].get(k)
        if p:
            print(f"  {k:26s} {_fmt(p['value']):>10} ± {_fmt(p['std']):<9} {p['unit']:16s} {p['source']}")
    keys = ("accel_rms_mps2", "velocity_rms_mps", "voltage_rms_v", "energy_error_fraction", "gyro_rms_radps")
    print("| model | " + " | ".join(keys) + " |")
    for cand, e in r.replay.errors.items():
        print(f"| {cand} | " + " | ".join(_fmt(e.get(k)) for k in keys) + " |")


def truth_flight(d: Path) -> tuple[Path, dict[str, float]]:
    """The known-truth flight of tests/identify/test_known_truth.py as a ULog, and its true parameters."""
    from tests.identify.test_known_truth import PHASES, TRUTH, _truth
    from vinecli.autopilot.registry import make_autopilot
    from vinecli.flightlog.from_run import flightlog_from_run
    from vinecli.flightlog.ulog_write import write_ulog
    from vinecli.sim.runner import run_simulation
    from vinecli.specs.mission import MissionSpec
    from vinecli.vehicle import load_vehicle
    from vinecli.world import build_world, load_world

    (d / "truth.yaml").write_text(TRUTH)
    world = load_world(build_world(REPO / "worlds" / "flat.yaml", d / "world"))
    ap = make_autopilot("builtin")
    try:
        res = run_simulation(world, MissionSpec(name="truth", vehicle=str(d / "truth.yaml"), max_duration_s=120,
                                                record_rate_hz=100, phases=PHASES), ap, seed=3)
    finally:
        ap.close()
    truth = load_vehicle(d / "truth.yaml")
    return write_ulog(flightlog_from_run(res.timeseries, truth), d / "truth.ulg"), _truth(truth)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="x500")
    ap.add_argument("--mass", type=float, default=None)
    ap.add_argument("--no-truth", action="store_true")
    args = ap.parse_args()
    from vinecli.identify.fit import fit_flight_log

    logs = [p for p in (LOGS / "TestFlight1.ulg", LOGS / "3.BIN") if p.is_file()]
    if not logs:
        print(f"no real logs in {LOGS} (../shared absent)")
    for p in logs:
        t0 = time.perf_counter()
        r = fit_flight_log(p, base=args.base, mass_kg=args.mass)
        report(p.name, r, time.perf_counter() - t0)
    if args.no_truth:
        return
    with tempfile.TemporaryDirectory() as tmp:
        ulg, truth = truth_flight(Path(tmp))
        t0 = time.perf_counter()
        r = fit_flight_log(ulg, base=args.base)
        report("known truth (simulated flight, tests/identify)", r, time.perf_counter() - t0)
        print("\nknown truth: fitted vs true")
        for k, v in truth.items():
            got = r.report["parameters"][k]["value"]
            print(f"  {k:24s} true {v:.5g}  fitted {got:.5g}  {100 * (got - v) / v:+.2f} %")


if __name__ == "__main__":
    main()
