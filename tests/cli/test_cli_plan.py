"""``vinecli plan import``: a QGroundControl .plan flown in the real loop; ``plan rows`` on a built world."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import yaml
from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.geo import GeoOrigin
from vinecli.missions.spec_io import load_mission

runner = CliRunner()


def small_plan(path: Path, origin: GeoOrigin) -> None:
    def ll(e: float, n: float) -> list[float]:
        lat, lon, _ = origin.enu_to_geodetic(e, n, 0.0)
        return [lat, lon]

    def item(cmd: int, frame: int, params: list) -> dict:
        return {"type": "SimpleItem", "command": cmd, "frame": frame, "params": params, "autoContinue": True}

    items = [
        item(22, 3, [0, 0, 0, None, *ll(0, 0), 2.5]),
        item(178, 2, [1, 2.0, -1, 0, 0, 0, 0]),
        item(16, 3, [0, 0, 0, None, *ll(2, 0), 2.5]),
        item(187, 2, [0.6, None, None, None, None, None, 1]),   # 0.6 x 0.1 L/s
        item(16, 3, [0, 0, 0, None, *ll(12, 0), 2.5]),
        item(187, 2, [0, None, None, None, None, None, 1]),
        item(21, 3, [0, 0, 0, None, *ll(12, 0), 0]),
    ]
    plan = {"fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
            "mission": {"version": 2, "firmwareType": 12, "vehicleType": 2, "hoverSpeed": 2,
                        "plannedHomePosition": [*ll(0, 0), origin.alt], "items": items},
            "geoFence": {"version": 2, "polygons": [], "circles": []}}
    path.write_text(json.dumps(plan))


def test_import_plan_and_fly_it(flat_world_dir: Path, tmp_path: Path) -> None:
    origin = GeoOrigin(47.397742, 8.545594, 488.0)  # worlds/flat.yaml
    plan = tmp_path / "row.plan"
    small_plan(plan, origin)
    mission = tmp_path / "row.yaml"
    r = runner.invoke(app, ["plan", "import", str(plan), "--world", str(flat_world_dir), "--out", str(mission)])
    assert r.exit_code == 0, r.output
    m = load_mission(mission)
    assert [p.type for p in m.phases] == ["takeoff", "waypoints", "sprayer", "waypoints", "sprayer", "land"]
    assert m.phases[3].waypoints[0][:2] == pytest.approx((12.0, 0.0), abs=0.01)
    data = yaml.safe_load(mission.read_text())
    data["tank_fill_l"] = 1.0
    data["checks"] = [
        {"name": "sprayed", "quantity": "tank_level_l", "reduce": "final", "op": "between", "bound": [0.5, 0.9]},
        {"name": "flow", "quantity": "tank_flow_lps", "reduce": "max", "op": "within_pct", "bound": 1, "reference": 0.06},
        {"name": "reached", "quantity": "pos_enu_x_m", "reduce": "final", "op": "between", "bound": [11.0, 13.0]},
    ]
    mission.write_text(yaml.safe_dump(data))
    out = tmp_path / "runs"
    r = runner.invoke(app, ["run", "mission", str(mission), "--world", str(flat_world_dir), "--out", str(out)])
    assert r.exit_code == 0, r.output
    t = pq.read_table(out / "row-s0" / "timeseries.parquet")
    flow = t.column("tank_flow_lps").to_numpy()
    x = t.column("pos_enu_x_m").to_numpy()
    on = flow > 0
    assert on.any() and x[on].min() >= 1.0 and x[on].max() <= 12.8  # spraying only along the row


def test_import_plan_bad_item_exits_2(flat_world_dir: Path, tmp_path: Path) -> None:
    plan = tmp_path / "bad.plan"
    small_plan(plan, GeoOrigin(47.397742, 8.545594, 488.0))
    d = json.loads(plan.read_text())
    d["mission"]["items"][4]["command"] = 31  # NAV_LOITER_TO_ALT: not supported
    plan.write_text(json.dumps(d))
    out = tmp_path / "m.yaml"
    r = runner.invoke(app, ["plan", "import", str(plan), "--world", str(flat_world_dir), "--out", str(out)])
    assert r.exit_code == 2 and "bad.plan" in r.output and "mission.items[4]: unsupported command 31" in r.output
    assert not out.exists()



def test_plan_swath_prints_and_plots_the_effective_swath(tmp_path: Path) -> None:
    from vinecli.spray.swath import swath_pattern
    from vinecli.vehicle import load_vehicle

    out = tmp_path / "swath"
    r = CliRunner().invoke(app, ["plan", "swath", "--vehicle", "x500-sprayer", "--height", "2", "--speed", "3",
                                 "--out", str(out)])
    assert r.exit_code == 0, r.output
    doc = json.loads((out / "swath.json").read_text())
    p = swath_pattern(load_vehicle("x500-sprayer"), 2.0, 3.0)
    assert doc["effective_swath_m"] == pytest.approx(p.effective_m) and doc["cv_at_effective"] <= 0.10
    assert f"effective swath {p.effective_m:.2f} m" in r.output
    assert (out / "swath.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = CliRunner().invoke(app, ["plan", "swath", "--out", str(out)])
    assert again.exit_code == 2  # nothing overwritten without --overwrite
