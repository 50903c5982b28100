"""Deposition in real runs (flat world, real loop and autopilot): outputs, determinism, and the spray checks
failing for a run stopped mid-row by a geofence hold (the failsafe switches the sprayer off: no overdose)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import rasterio
from repo_paths import REPO

from vinecli.runs import RunRequest, run_mission

SPRAY = """\
name: {name}
description: two 12 m rows at 20 L/ha on flat ground
vehicle: x500-sprayer
tank_fill_l: 0.4
max_duration_s: {maxdur}
record_rate_hz: 25
{fence}
phases:
  - {{type: takeoff, altitude_agl_m: 2.0}}
  - {{type: spray, rows: [[[0.0, 2.0], [0.0, 14.0]], [[3.6, 14.0], [3.6, 2.0]]], height_agl_m: 2.0,
      speed_mps: 2.0, rate_lpha: 20.0}}
  - {{type: land}}
checks:
  - {{name: spray_coverage, quantity: "metric:row_coverage_fraction", op: ">=", bound: 0.9}}
  - {{name: spray_rate_on_rows, quantity: "metric:mean_rate_lpha_on_rows", op: between, bound: [10.0, 40.0]}}
  - {{name: spray_drift, quantity: "metric:drift_outside_fence_fraction", op: "<=", bound: 0.05}}
  - {{name: spray_volume_balance, quantity: "metric:deposit_balance_error", op: "<=", bound: 1.0e-6}}
"""


def mission(d: Path, name: str, fence: str = "", maxdur: float = 60.0) -> Path:
    p = d / f"{name}.yaml"
    p.write_text(SPRAY.format(name=name, fence=fence, maxdur=maxdur))
    return p


def test_spray_run_writes_deposition_and_is_deterministic(flat_world_dir: Path, tmp_path: Path) -> None:
    m = mission(tmp_path, "rows")
    a = run_mission(RunRequest(m, flat_world_dir, tmp_path / "a", seed=4))
    b = run_mission(RunRequest(m, flat_world_dir, tmp_path / "b", seed=4))
    assert a.passed, a.failed_checks
    ra, rb = Path(a.run_dir), Path(b.run_dir)
    assert (ra / "deposition.tif").read_bytes() == (rb / "deposition.tif").read_bytes()
    doc = json.loads((ra / "deposition.json").read_text())
    met = a.metrics
    # the rate asked in L/ha became the flow 20 x track width x 2 m/s / 10 000; the rows are 3.6 m apart, wider
    # than the effective swath: a pass over each, whose track width doses the row's canopy band. The wake carries
    # the drops down as a plume ~1 m wide (spray/wake.py): both are far narrower than the cones' swath edge to edge
    sp = doc["spray_phase"]
    assert sp["passes"]["mode"] == "rows" and sp["passes"]["count"] == 2
    # (deposition.json gives the flow to 6 decimals: 0.0044 L/s to ±5e-7)
    assert sp["flow_lps"] == pytest.approx(20.0 * sp["track_width_m"] * 2.0 / 1e4, abs=5e-7)
    assert max(sp["track_width_m"], sp["effective_swath_m"]) < 0.5 * sp["swath_m"]
    assert "speed-scaled" in doc["sprayer_law"]["flow"]
    # the dose judged by default on each row's planned stretch: the default checks are in the summary and pass
    checks = {c["name"]: c for c in a.checks}
    assert {"dose_row_rates", "dose_hot_spots", "dose_gaps", "dose_coverage", "dose_drift",
            "dose_no_spray"} <= set(checks)
    assert all(checks[n]["passed"] and checks[n]["implicit"] for n in checks if n.startswith("dose_"))
    for row in doc["rows"]:
        assert row["planned_m"] == pytest.approx([0.0, 12.0]) and row["segment_m"] == 0.5
        assert abs(row["mean_rate_lpha"] / 20.0 - 1.0) <= 0.15 and row["faults"] == []
    assert met["deposit_balance_error"] <= 1e-6
    with rasterio.open(ra / "deposition.tif") as ds:
        assert ds.crs is None  # flat world: local ENU grid, origin in the tags
        tags = ds.tags()
        assert float(tags["ORIGIN_LAT"]) == pytest.approx(47.397742) and tags["UNITS"] == "L/ha"
        rate = ds.read(1, masked=True)
        cell = ds.transform.a
        assert ds.dtypes[0] == "float32"
        on_grid = float(rate.sum()) * cell * cell / 1e4
        x0, y_top = ds.transform.c, ds.transform.f
    assert on_grid == pytest.approx(met["deposit_on_grid_l"], rel=1e-4)
    g = doc["grid"]
    assert (x0, y_top) == pytest.approx((g["x0_m"], g["y0_m"] + g["ny"] * g["cell_m"]))
    # everything the tank lost was emitted (1 kg/L): 0.4 L minus what is left
    left_l = met["final_mass_kg"] - met["rigid_mass_kg"]
    assert met["deposit_emitted_l"] == pytest.approx(0.4 - left_l, rel=1e-6)
    assert met["deposit_emitted_l"] > 0.04  # 20 L/ha over a ~1 m track at 2 m/s over two 12 m rows
    assert met["row_coverage_fraction"] >= 0.9


def test_a_geofence_hold_mid_row_fails_the_spray_checks_with_the_sprayer_off(flat_world_dir: Path, tmp_path: Path) -> None:
    # the fence 1 m west of the first row (preflight's 0.9 m margin); a westward gust shoves the vehicle
    # through it mid-row: geofence hold until the time limit, sprayer off at the breach
    fence = ("geofence: {polygon_enu: [[-1.0, -10.0], [10.0, -10.0], [10.0, 20.0], [-1.0, 20.0]], action: hold}\n"
             "wind: {law: {type: gust, peak_mps: 24.0, start_s: 6.0, duration_s: 4.0, heading_deg: 270.0}}")
    s = run_mission(RunRequest(mission(tmp_path, "stuck", fence=fence, maxdur=45.0), flat_world_dir, tmp_path / "runs",
                               seed=4))
    failed = {c["name"] for c in s.failed_checks}
    assert "spray_coverage" in failed
    assert s.metrics["row_coverage_fraction"] < 0.5
    assert s.metrics["deposit_balance_error"] <= 1e-6
    summary = json.loads((Path(s.run_dir) / "summary.json").read_text())
    (fs,) = summary["failsafes"]
    assert fs["cause"] == "geofence" and fs["action"] == "hold"
    # nothing more left the tank after the breach: well under the 0.4 L it would have emptied onto one spot
    assert 0.0 < s.metrics["deposit_emitted_l"] < 0.05


def test_the_deposition_grid_is_configurable(flat_world_dir: Path, tmp_path: Path) -> None:
    from vinecli.missions.spec_io import load_mission
    from vinecli.sim.runner import run_simulation
    from vinecli.sitl.options import make_run_autopilot
    from vinecli.spray.deposition import DepositionConfig
    from vinecli.world import load_world

    spec = load_mission(mission(tmp_path, "cells")).model_copy(update={"truth": True})
    ap = make_run_autopilot("builtin")
    try:
        res = run_simulation(load_world(flat_world_dir), spec, ap, seed=1, deposition=DepositionConfig(cell_m=0.05))
    finally:
        ap.close()
    dep = res.deposition
    # 20 L/ha over a ~1 m track at 2 m/s: 0.004 L/s, ~0.06 L over the two 12 m rows and their run-ins
    assert dep.grid.cell == 0.05 and dep.balance_error <= 1e-6 and dep.emitted_l > 0.04
    ap = make_run_autopilot("builtin")
    try:
        off = run_simulation(load_world(flat_world_dir), spec, ap, seed=1, deposition=False)
    finally:
        ap.close()
    assert off.deposition is None


def test_deposition_map_of_a_dsm_world_is_in_the_dsm_crs(tmp_path: Path, sample_world_dir: Path) -> None:
    from pyproj import Transformer

    from vinecli.world import load_world

    world = sample_world_dir
    m = tmp_path / "short.yaml"
    m.write_text(SPRAY.format(name="short", fence="", maxdur=60.0).replace(
        "[[[0.0, 2.0], [0.0, 14.0]], [[3.6, 14.0], [3.6, 2.0]]]", "[[[-3.0, -10.0], [-3.0, 0.0]]]"))
    s = run_mission(RunRequest(m, world, tmp_path / "runs", seed=2))
    doc = json.loads((Path(s.run_dir) / "deposition.json").read_text())
    origin = load_world(world).origin  # the world's georeference: the DSM's CRS grid (vinecli.geo.GeoFrame)
    dsm = REPO / "worlds" / "sample" / "fieldimager_potato_plots_dsm_3cm_utm16n.tif"
    with rasterio.open(dsm) as d, rasterio.open(Path(s.run_dir) / "deposition.tif") as dep:
        assert dep.crs == d.crs
        # the ENU point (e, n) of a grid cell lands where pyproj puts its latitude/longitude in the DSM's CRS
        g = doc["grid"]
        e, n = g["x0_m"] + 10.5 * g["cell_m"], g["y0_m"] + (g["ny"] - 20.5) * g["cell_m"]
        x, y = dep.transform * (10.5, 20.5)
        lat, lon, _ = origin.enu_to_geodetic(e, n, 0.0)
        xe, ye = Transformer.from_crs("EPSG:4326", d.crs, always_xy=True).transform(lon, lat)
        assert abs(x - xe) < 0.005 and abs(y - ye) < 0.005
        # the map lies on the DSM (the grid is clipped to the terrain)
        b, bd = dep.bounds, d.bounds
        assert bd.left - 1 < b.left and b.right < bd.right + 1 and bd.bottom - 1 < b.bottom and b.top < bd.top + 1
