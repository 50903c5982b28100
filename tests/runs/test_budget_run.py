"""The spray budget of real runs (flat vineyard world with hedges and air, real loop and autopilot): budget.json
balances, canopy_deposit.tif agrees with it (read back with GDAL through rasterio), the drift curve table, the
metrics and default checks (and overriding them), the world's canopy in world.json and world.sdf, the figure."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from lxml import etree

from vinecli.runs import RunRequest, recheck_run, run_mission

WORLD = """\
name: flat-vines
terrain: {type: flat, z_m: 0.0, size_m: 120.0}
origin: {lat: 47.397742, lon: 8.545594, alt: 488.0}
vehicle: x500-sprayer
spawn: {x_m: -6.0, y_m: 0.0, yaw_deg: 90.0}
wind: {law: {type: constant, velocity_enu: [1.5, 0.0, 0.0]}}
rows:
  - [[0.0, 2.0], [0.0, 14.0]]
  - [[1.8, 2.0], [1.8, 14.0]]
  - [[3.6, 2.0], [3.6, 14.0]]
canopy: {bbch: 71, profile: [0.5, 1.0, 1.5], rows: [{row: 2, lad_m2m3: 6.0}]}
air: {temperature_c: 24.0, relative_humidity_pct: 50.0}
"""

SPRAY = """\
name: {name}
vehicle: x500-sprayer
tank_fill_l: 0.3
max_duration_s: 60
record_rate_hz: 25
phases:
  - {{type: takeoff, altitude_agl_m: 2.0}}
  - {{type: spray, rows: [0, 2], height_agl_m: 2.0, speed_mps: 2.0, rate_lpha: 20.0}}
  - {{type: land}}
checks:
{checks}
"""


@pytest.fixture(scope="module")
def vine_world(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from vinecli.world import build_world

    d = tmp_path_factory.mktemp("vines")
    (d / "w.yaml").write_text(WORLD)
    return build_world(d / "w.yaml", d / "world")


@pytest.fixture(scope="module")
def run(vine_world: Path, tmp_path_factory: pytest.TempPathFactory):
    d = tmp_path_factory.mktemp("budget-run")
    (d / "m.yaml").write_text(SPRAY.format(name="vines", checks="  - {name: done, quantity: status, op: '==', "
                                                               "bound: completed}"))
    return run_mission(RunRequest(d / "m.yaml", vine_world, d / "runs", seed=2))


def test_world_has_the_canopy_in_json_and_sdf(vine_world: Path) -> None:
    doc = json.loads((vine_world / "world.json").read_text())
    c = doc["canopy"]
    assert c["bbch"] == 71 and c["profile"] == pytest.approx([0.5, 1.0, 1.5])
    assert [h["lad_m2m3"] for h in c["hedges"]] == [4.0, 4.0, 6.0]  # BBCH 71 default, row 2 overridden
    assert c["spacing_m"] == pytest.approx(1.8)
    assert doc["air"] == {"temperature_c": 24.0, "relative_humidity_pct": 50.0}
    sdf = etree.parse(str(vine_world / "world.sdf"))
    hedges = [m for m in sdf.iter("model") if m.get("name", "").startswith("hedge_")]
    assert len(hedges) == 3
    size = [float(v) for v in hedges[0].find(".//box/size").text.split()]
    assert size == pytest.approx([12.0, 0.5, 2.15 - 0.55])  # row length, width, foliage depth (BBCH 71)
    assert hedges[0].find(".//collision") is None  # porous: visual only


def test_budget_json_balances_and_matches_its_maps(run) -> None:
    assert run.status == "completed", run.status_message
    rd = Path(run.run_dir)
    doc = json.loads((rd / "budget.json").read_text())
    fr = doc["fractions"]
    assert set(fr) == {"canopy", "ground_in_field", "ground_off_field", "airborne_out", "evaporated"}
    assert abs(sum(fr.values()) - 1.0) <= max(doc["balance_error"], 1e-6) <= 0.01
    assert fr["canopy"] > 0.02 and fr["evaporated"] > 0.0 and fr["ground_in_field"] > 0.3
    vol = doc["volumes_l"]
    assert vol["emitted"] == pytest.approx(run.metrics["deposit_emitted_l"], rel=1e-9)
    # the canopy map holds the canopy volume (what lands on the grid) and its per-leaf band is consistent
    with rasterio.open(rd / "canopy_deposit.tif") as ds:
        assert ds.count == 2 and ds.tags()["UNITS"].startswith("µL/cm²")
        per_leaf = ds.read(1, masked=True)
        lpha = ds.read(2, masked=True)
        cell = ds.transform.a
    assert float(lpha.sum()) * cell * cell / 1e4 == pytest.approx(doc["maps"]["canopy_on_grid_l"], rel=1e-4)
    assert doc["maps"]["canopy_on_grid_l"] + doc["maps"]["canopy_off_grid_l"] == pytest.approx(vol["canopy"], rel=1e-6)
    assert float(per_leaf.max()) > 0
    # per row: the targeted rows 0 and 2 released the spray (over row 1 at most the pump's run-down after the
    # sections closed: its lag), row 2's denser hedge caught more per leaf area
    rows = {r["row"]: r for r in doc["rows"]}
    assert rows[0]["released_l"] > 0 and rows[2]["released_l"] > 0
    assert rows[1]["released_l"] <= 0.01 * min(rows[0]["released_l"], rows[2]["released_l"])
    assert rows[0]["canopy_l"] > 0 and rows[2]["canopy_l"] > 0
    assert rows[2]["deposit_ulpcm2_per_lpha"] == pytest.approx(rows[2]["deposit_ulpcm2"] / 20.0, rel=1e-4)
    # conditions are recorded
    assert doc["conditions"]["wind_mean_enu_mps"][0] == pytest.approx(1.5, abs=0.05)
    assert doc["conditions"]["drop_spectrum"]["vmd_um"] == 200.0
    assert doc["conditions"]["canopy"]["bbch"] == 71


def test_drift_curve_table_metrics_and_default_checks(run) -> None:
    rd = Path(run.run_dir)
    doc = json.loads((rd / "budget.json").read_text())
    with open(rd / "drift_curve.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [float(r["distance_m"]) for r in table] == [1, 3, 5, 10, 15, 20, 30, 50]
    curve = {p["distance_m"]: p["percent_of_applied"] for p in doc["drift_curve"]}
    for r in table:
        assert float(r["percent_of_applied"]) == pytest.approx(curve[float(r["distance_m"])], rel=1e-5, abs=1e-9)
    assert not doc["drift"]["calm"] and doc["drift"]["downwind_normal_enu"] == pytest.approx([1.0, 0.0], abs=1e-9)
    assert doc["drift"]["last_rows"] == [2]  # east row: the wind blows east
    m = run.metrics
    assert m["budget_drift_5m_percent"] == pytest.approx(curve[5.0], rel=1e-6, abs=1e-12)
    assert m["budget_canopy_fraction"] == pytest.approx(doc["fractions"]["canopy"], rel=1e-6)
    names = {c["name"]: c for c in run.checks}
    assert names["budget_drift_5m"]["bound"] == 3.62 and names["budget_canopy_share"]["bound"] == 0.05


def test_a_mission_check_overrides_the_default(run, vine_world: Path, tmp_path: Path) -> None:
    summary, results = recheck_run(
        run.run_dir, mission=_mission(tmp_path, "  - {name: strict, quantity: 'metric:budget_canopy_fraction', "
                                                "op: '>=', bound: 0.99}"))
    by = {r.name: r for r in results}
    assert "budget_canopy_share" not in by and not by["strict"].passed
    assert "budget_drift_5m" in by  # the other default stays


def test_budget_figure_renders(run) -> None:
    from vinecli.report.plots import expected_size, png_size, render_figures

    fig = render_figures(run.run_dir, only=["fig25"])["fig25"]
    assert fig["png"] is not None, fig["note"]
    assert png_size(fig["png"]) == expected_size("fig25")


def _mission(d: Path, checks: str) -> Path:
    p = d / "override.yaml"
    p.write_text(SPRAY.format(name="override", checks=checks))
    return p


def test_no_budget_without_spraying(flat_world_dir: Path, tmp_path: Path) -> None:
    m = tmp_path / "hover.yaml"
    m.write_text("name: hover\nvehicle: x500-sprayer\nmax_duration_s: 8\nphases:\n"
                 "  - {type: takeoff, altitude_agl_m: 2.0}\n  - {type: land}\n")
    s = run_mission(RunRequest(m, flat_world_dir, tmp_path / "runs", seed=0))
    rd = Path(s.run_dir)
    assert not (rd / "budget.json").exists() and not (rd / "canopy_deposit.tif").exists()
    assert "budget_canopy_fraction" not in s.metrics
    assert np.isfinite(s.sim_time_s)
