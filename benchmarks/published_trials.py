"""The spray budget against published multirotor spraying trials in vineyards, side by side (docs/budget.md).

Biglia et al. 2022 (Sci. Total Environ. 845:157292): the twelve configurations T1-T12 (vehicle, nozzles,
height, speed, flow, weather of Tables 1, 2, A1; vineyard of §2.4) read by the paper's collectors,
standardised to 250 µL per cm travelled; and an ISO 22866 drift trial against the basic drift values
(Rautmann et al. 2001) that Herbst et al. 2023 and Bonds et al. 2024 compare drone drift with.
tests/spray/test_published_trials.py asserts the agreement this prints.

Usage::

    python benchmarks/published_trials.py [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, help="write the figures as JSON")
    args = ap.parse_args(argv)

    from vinecli.spray.published_trials import BIGLIA_2022, CONFIGS, RAUTMANN_2001, drift_trial, reading
    from vinecli.spray.spray_trial import run_trial

    r = {c.name: reading(c) for c in CONFIGS}
    print("config  mode   nozzle  speed  canopy µL/cm²  ground µL/cm²  budget: canopy / in field / off / evap")
    for c in CONFIGS:
        x = r[c.name]
        print(f"{c.name:6s}  {c.mode:5s}  {'conv' if c.conventional else 'AI':6s}  {c.speed_mps:4.0f}   {x['canopy']:12.3f}"
              f"  {x['ground']:13.3f}  {x['fraction_canopy']:.2f} / {x['fraction_ground_in_field']:.2f} / "
              f"{x['fraction_ground_off_field']:.2f} / {x['fraction_evaporated']:.2f}")

    def mean(names: list[str], key: str) -> float:
        return float(np.mean([r[n][key] for n in names]))

    rows = [
        ("canopy, band, conventional (§3.1, Fig. 5)", "canopy_band_conventional", mean(["T9", "T10"], "canopy")),
        ("canopy, band (abstract)", "canopy_band", mean(["T9", "T10", "T11", "T12"], "canopy")),
        ("canopy, broadcast (abstract)", "canopy_broadcast", mean([f"T{i}" for i in range(1, 9)], "canopy")),
        ("ground, band (§3.3, Fig. 9)", "ground_band", mean(["T9", "T10", "T11", "T12"], "ground")),
        ("ground, 1-way broadcast (§3.3, Fig. 9)", "ground_broadcast_1way", mean(["T1", "T2", "T3", "T4"], "ground")),
        ("ground, 2-way broadcast (§3.3, Fig. 9)", "ground_broadcast_2way", mean(["T5", "T6", "T7", "T8"], "ground")),
    ]
    print("\nBiglia et al. 2022, standardised deposits, µL/cm²        paper   vinecli   ratio")
    out: dict[str, object] = {"biglia_2022": {}, "configs": r}
    for label, key, model in rows:
        paper = BIGLIA_2022[key]
        print(f"{label:52s} {paper:6.3f}   {model:7.3f}   {model / paper:5.2f}")
        out["biglia_2022"][key] = {"paper": paper, "vinecli": model}  # type: ignore[index]

    print("\nISO 22866 drift trial, % of applied     3 m     5 m    10 m    15 m    20 m")
    curves = {}
    for conv, name in ((True, "UASS, conventional (HCI)"), (False, "UASS, air inclusion (HCA)")):
        b, _ = run_trial(drift_trial(conv))
        curves[name] = {p["distance_m"]: p["percent_of_applied"] for p in b.drift}
    for name, c in {**curves, **{f"Rautmann 2001, {k}": v for k, v in RAUTMANN_2001.items()}}.items():
        print(f"{name:38s} " + " ".join(f"{c[d]:7.3f}" for d in (3.0, 5.0, 10.0, 15.0, 20.0)))
    out["drift"] = {k: {str(d): v for d, v in c.items()} for k, c in curves.items()}
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
