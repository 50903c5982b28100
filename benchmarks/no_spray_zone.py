"""Liquid in a grower's no-spray zone and the dose of the rows around it: the grower case of
``tests/gis/test_gis_world.py`` (three rows 2.5 m apart, the middle one cut by a stream grown by a 1 m buffer,
x500-sprayer at 2 m and 3 m/s) flown with the built-in autopilot, and measured from the run directory alone:

* the share of the emitted liquid landing in the zone (grown by its buffer): ``deposition.tif`` summed over the
  cells whose centres lie in ``world.json``'s ``gis.no_spray_enu``, over ``totals.emitted_l`` (the same measure on
  any tree, with or without the ``deposit_in_no_spray_fraction`` metric, printed beside it when present);
* per row (the two pieces of the cut row and the rows beside the zone): the judged stretch, mean rate / asked,
  covered share, thinnest and hottest 1 m window (``deposition.json``), and the mean rate on the canopy band
  over the whole piece (the tif), so a stretch shortened by the plan does not hide a thin end;
* the checks that failed.

``--no-clearance`` flies the same tree with the plan's clearance at the zones set to 0 (the passes end at the zone's
edge, as main did before the clearance): the baseline in the same run.

    .venv/bin/python benchmarks/no_spray_zone.py [--rate 20 40] [--seed 1] [--keep DIR] [--no-clearance]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def _grid_rates(run_dir: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, dict[str, Any]]:
    """(x, y cell centres ENU m, rate L/ha (ny, nx) row 0 south, cell m, deposition.json) of a run."""
    import rasterio

    dep = json.loads((run_dir / "deposition.json").read_text())
    g = dep["grid"]
    with rasterio.open(run_dir / "deposition.tif") as ds:
        rate = np.flipud(ds.read(1).astype(np.float64))
        rate[rate == ds.nodata] = 0.0
    x = g["x0_m"] + (np.arange(g["nx"]) + 0.5) * g["cell_m"]
    y = g["y0_m"] + (np.arange(g["ny"]) + 0.5) * g["cell_m"]
    return x, y, rate, float(g["cell_m"]), dep


def measure(run_dir: Path, world_dir: Path) -> dict[str, Any]:
    """The figures of one run (module doc)."""
    from shapely import contains_xy
    from shapely.geometry import LineString, Polygon

    x, y, rate, cell, dep = _grid_rates(run_dir)
    world = json.loads((world_dir / "world.json").read_text())
    gx, gy = np.meshgrid(x, y)
    vol = rate * cell * cell / 1e4  # L per cell
    inside = np.zeros(gx.shape, bool)
    for z in world["gis"]["no_spray_enu"]:
        inside |= contains_xy(Polygon(z), gx, gy)
    emitted = float(dep["totals"]["emitted_l"])
    asked = float(dep["spray_phase"]["rate_lpha"])
    half = 0.5 * float(dep["canopy_width_m"])
    rows = []
    for r in dep["rows"]:
        line = LineString(r["polyline_enu"])
        band = contains_xy(line.buffer(half, cap_style="flat"), gx, gy)
        win = r.get("window_ratio") or [None]
        wins = [w for w in win if w is not None]
        rows.append({"row": r["row"], "length_m": round(line.length, 2), "planned_m": r["planned_m"],
                     "not_judged_m": r.get("not_judged_m"), "mean/asked": r["mean_rate_lpha"] / asked,
                     "covered": r["covered_fraction"], "windows": (min(wins), max(wins)) if wins else None,
                     "whole piece mean/asked": float(rate[band].mean()) / asked})
    summ = json.loads((run_dir / "summary.json").read_text())
    return {"emitted_l": emitted, "in_zone_l": float(vol[inside].sum()),
            "in_zone_fraction": float(vol[inside].sum()) / emitted,
            "metric": dep["metrics"].get("deposit_in_no_spray_fraction"), "rows": rows,
            "failed": [(c["name"], c["value"]) for c in summ["checks"] if not c["passed"]], "status": summ["status"]}


def fly(rate: float, seed: int, work: Path) -> tuple[Path, Path]:
    """Build the grower world under ``work`` and fly its spray job at ``rate`` L/ha; (run dir, world dir)."""
    import yaml

    from tests.gis.test_gis_world import grower_world
    from vinecli.runs import RunRequest, run_mission
    from vinecli.world import build_world

    world = work / "world"
    if not world.exists():
        build_world(grower_world(work), world)
    m = work / f"m{rate:g}.yaml"
    m.write_text(yaml.safe_dump({
        "name": f"grower-{rate:g}", "vehicle": "x500-sprayer", "max_duration_s": 120,
        "phases": [{"type": "takeoff", "altitude_agl_m": 2.5},
                   {"type": "spray", "rows": "world", "height_agl_m": 2.0, "speed_mps": 3.0, "rate_lpha": rate},
                   {"type": "land"}]}))
    s = run_mission(RunRequest(m, world, work / "runs", seed=seed))
    return Path(s.run_dir), world


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, nargs="+", default=[20.0, 40.0], help="asked rates, L/ha")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--keep", type=Path, help="fly under this directory and keep it")
    ap.add_argument("--no-clearance", action="store_true", help="the plan's clearance at the zones set to 0")
    a = ap.parse_args(argv)
    if a.no_clearance:
        import vinecli.rows.plan

        vinecli.rows.plan.clearance_m = lambda pattern, end_margin_m: 0.0  # type: ignore[assignment]
    with tempfile.TemporaryDirectory() as tmp:
        work = a.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        for rate in a.rate:
            run, world = fly(rate, a.seed, work)
            m = measure(run, world)
            print(f"{rate:g} L/ha, seed {a.seed}: {m['status']}; emitted {m['emitted_l']:.3f} L, in the zone "
                  f"{m['in_zone_l'] * 1e3:.2f} mL = {m['in_zone_fraction']:.3%} (metric: {m['metric']}); "
                  f"failed checks: {m['failed'] or 'none'}")
            for r in m["rows"]:
                w = r["windows"]
                print(f"  row {r['row']} ({r['length_m']} m, judged {r['planned_m']}, not judged {r['not_judged_m']}): "
                      f"mean {r['mean/asked']:.3f}x asked, covered {r['covered']:.3f}, windows "
                      f"{'-' if w is None else f'{w[0]:.2f}-{w[1]:.2f}x'}, whole piece {r['whole piece mean/asked']:.3f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
