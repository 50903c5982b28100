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
    ap.add_argument("--png", type=Path, help="draw the Biglia comparison (paper vs model) to this PNG")
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

    import dataclasses

    print("\nOne pass along the edge row, 2 m/s crosswind, % of applied   5 m    10 m    20 m    30 m    50 m")
    for vmd in (145.0, 150.0, 200.0):
        base = drift_trial(True, 2.0)
        x = base.rows[-1][0][0]
        trial = dataclasses.replace(base, vehicle=dataclasses.replace(base.vehicle, vmd_um=vmd),
                                    passes=[((x, -5.0), (x, 67.0))])
        b, _ = run_trial(trial)
        c = {p["distance_m"]: p["percent_of_applied"] for p in b.drift}
        print(f"M600-class, hollow cone VMD {vmd:.0f} µm{'':22s}" + " ".join(f"{c[d]:7.3f}" for d in (5.0, 10.0, 20.0,
                                                                                                   30.0, 50.0)))
        out.setdefault("edge_row", {})[str(vmd)] = c  # type: ignore[union-attr]

    from vinecli.spray.budget import BudgetConfig
    from vinecli.spray.published_trials import bench_trial_mg1p, vineyard_bench_trial

    far = (3.0, 5.0, 7.5, 10.0, 15.0, 20.0, 50.0)
    print("\nThe drift trials named as targets (conditions as read; results not reachable), % of applied"
          "\n" + " " * 52 + "".join(f"{d:>7g} m" for d in far))
    for label, make in (("Wang C. et al. 2020, vineyard bench, one edge pass", vineyard_bench_trial),
                        ("Agronomy 2023 13:270, MG-1P over the drift bench", bench_trial_mg1p)):
        for conv in (True, False):
            trial = dataclasses.replace(make(conv), budget=BudgetConfig(drift_distances_m=far))
            b, _ = run_trial(trial)
            c = {p["distance_m"]: p["percent_of_applied"] for p in b.drift}
            name = f"{label}, {'conv' if conv else 'AI'}"
            print(f"{name:60s}" + "".join(f"{c[d]:9.3g}" for d in far))
            out.setdefault("targets", {})[name] = c  # type: ignore[union-attr]

    from vinecli.spray.swath import swath_pattern
    from vinecli.vehicle import load_vehicle

    print("\nEffective swath (CV <= 10 %, back and forth), m      model   published")
    for name, h, v, pub in (("ag-hexa-16", 2.5, 3.5, "3.0 (DJI T16 in vines, JKI-approved set-up)"),
                            ("x500-sprayer", 2.0, 2.0, "-")):
        pat = swath_pattern(load_vehicle(name), h, v)
        print(f"{name:16s} {h:.1f} m, {v:.1f} m/s                    {pat.effective_m:5.2f}   {pub}")
        out.setdefault("swath", {})[name] = pat.effective_m  # type: ignore[union-attr]
    if args.png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from vinecli.report.budget_plots import trial_comparison

        fig, ax = plt.subplots(figsize=(8, 4))
        trial_comparison(ax, [(label.split(" (")[0], BIGLIA_2022[key], model) for label, key, model in rows])
        ax.set_title("Biglia et al. 2022: band and broadcast spraying, paper vs vinecli", fontsize=10)
        fig.tight_layout()
        fig.savefig(args.png, dpi=110)
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
