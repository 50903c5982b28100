"""The shipped CI gate: pipelines/ci.yaml (thesis chapter 5) through the real loop and autopilot."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from repo_paths import REPO

from vinecli.batch import run_batch

EXPECTED = {
    "takeoff": ("completed", {"tank_force_at_rest", "liftoff_force_jump", "steady_climb_force",
                              "drag_opposes_vertical_motion", "altitude_reached"}),
    "overload": ("cannot_take_off", {"cannot_take_off", "stays_on_ground"}),
    "spray": ("completed", {"drain_time", "rotor_speed_follows_mass", "hover_law", "dose_row_rates"}),
    "gust": ("completed", {"holds_position", "rotors_follow_wind_period", "tilts_into_wind", "tilt_magnitude"}),
    "job": ("completed", {"several_sorties", "litres_per_sortie", "dose_row_rates", "dose_hot_spots", "dose_gaps"}),
}


@pytest.fixture(scope="module")
def ci_runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ci") / "runs"
    res = run_batch(REPO / "pipelines" / "ci.yaml", out, workers=2)
    assert [c.case for c in res.cases] == list(EXPECTED)
    return out


def test_ci_pipeline_passes_every_check(ci_runs: Path) -> None:
    batch = json.loads((ci_runs / "batch.json").read_text())
    assert batch["pipeline"] == "ci" and batch["passed"] is True
    assert (ci_runs / "_worlds" / "vineyard-sample" / "world.json").is_file()  # the world spec, built once
    for case in batch["cases"]:
        status, must = EXPECTED[case["case"]]
        s = json.loads((ci_runs / case["run_id"] / "summary.json").read_text())
        assert s["status"] == status, case
        checks = {c["name"]: c for c in s["checks"]}
        assert must <= set(checks)
        failed = [c for c in s["checks"] if not c["passed"]]
        assert not failed, failed
        assert s["world"]["name"] == "vineyard-sample" and len(s["world"]["rows_enu"]) == 16


def test_ci_thesis_numbers(ci_runs: Path) -> None:
    """The measured chapter-5 quantities, not just pass/fail."""
    def checks(case: str) -> dict[str, float]:
        s = json.loads((ci_runs / case / "summary.json").read_text())
        return {c["name"]: c["value"] for c in s["checks"]}

    t = checks("takeoff")
    assert abs(t["tank_force_at_rest"] - 1.0) <= 0.01          # 1 L water -> 9.81 N at rest
    assert t["liftoff_force_jump"] >= 0.05                      # inertial jump at lift-off
    assert abs(t["steady_climb_force"] - 1.0) <= 0.03           # back to the weight in the steady climb
    s = checks("spray")
    assert -0.02 <= s["drain_time"] - 1.0 <= 0.04               # the pump lags its command
    assert 0.4 <= s["hover_law"] <= 0.6                         # w ~ m^(1/2)
    j = json.loads((ci_runs / "job" / "summary.json").read_text())
    assert 4 <= len(j["sorties"]) == j["metrics"]["sorties"] <= 8  # the whole field at 50 L/ha takes ~6 tanks
    assert all(s["end_reason"] == "tank empty" for s in j["sorties"][:-1])
    assert all(abs(s["volume_l"] - 1.0) < 0.02 for s in j["sorties"][:-1])
    jc = checks("job")  # every row, the edge rows included, within ±15 %; no 1 m hot spot or gap (resumes)
    assert jc["dose_row_rates"] <= 0.15 and jc["dose_hot_spots"] <= 1.3 and jc["dose_gaps"] >= 0.6
    assert j["operations"]["field_capacity_ha_per_h"] > 0 and j["operations"]["idle_s"] > 0
    g = checks("gust")
    assert 0.9 <= g["rotors_follow_wind_period"] <= 1.1
    assert 0.75 <= g["tilt_magnitude"] <= 1.25                  # tilt ~ atan(F_drag / (m g))


def test_resume_skips_the_finished_ci_cases(ci_runs: Path) -> None:
    res = run_batch(REPO / "pipelines" / "ci.yaml", ci_runs, workers=1, resume=True)
    assert all(c.skipped and c.passed for c in res.cases)


def test_dask_executor_runs_a_real_mission(tmp_path: Path, ci_runs: Path) -> None:
    world = ci_runs / "_worlds" / "vineyard-sample"
    pipe = tmp_path / "p.yaml"
    pipe.write_text(f"name: dask-real\nworld: {world}\nmissions: [{REPO / 'pipelines' / 'missions' / 'takeoff.yaml'}]\n")
    res = run_batch(pipe, tmp_path / "runs", workers=1, executor="dask", dask_processes=False)
    assert res.cases[0].passed and res.cases[0].status == "completed"
    assert json.loads((tmp_path / "runs" / "batch.json").read_text())["executor"] == "dask"


def test_plan_rows_on_the_built_sample_world(ci_runs: Path, tmp_path: Path) -> None:
    """`vinecli plan rows WORLD_DIR`: the world's own rows, and rows detected on its height grid."""
    from typer.testing import CliRunner

    from vinecli.cli.app import app

    world = ci_runs / "_worlds" / "vineyard-sample"
    out = tmp_path / "rows.plan"
    r = CliRunner().invoke(app, ["plan", "rows", str(world), "--out", str(out), "--world-rows"])
    assert r.exit_code == 0, r.output
    items = json.loads(out.read_text())["mission"]["items"]
    duty = [i["params"][0] for i in items if i["command"] == 187]  # DO_SET_ACTUATOR: the pump's duty
    # the sprayer closed before the first transit (as PX4's upload), then on and off along each of the 16 rows
    assert duty[0] == 0 and sum(d > 0 for d in duty) == 16
    assert all(a > 0 and b == 0 for a, b in zip(duty[1::2], duty[2::2], strict=True))
    # --overwrite: the rows.geojson beside it is the first call's (vinecli refuses to replace a file it cannot
    # tell from a user's)
    r = CliRunner().invoke(app, ["plan", "rows", str(world), "--out", str(tmp_path / "det.plan"), "--detect",
                                 "--overwrite"])
    assert r.exit_code == 0 and "16 rows" in r.output and "spacing 0.9" in r.output


def test_spray_starts_at_the_row_nearest_the_spawn(ci_runs: Path) -> None:
    """The spawn is west of the rows: the spray mission targets rows 1 and 5 (indices into the world's
    rows) and the plan starts with the nearer one, row 1, not with row 5 further east."""
    batch = json.loads((ci_runs / "batch.json").read_text())
    run = next(c["run_id"] for c in batch["cases"] if c["case"] == "spray")
    events = [json.loads(line) for line in (ci_runs / run / "events.jsonl").read_text().splitlines()]
    plan = next(e for e in events if e["kind"] == "spray_plan")
    assert plan["data"]["mode"] == "rows" and len(plan["data"]["passes"]) == 2  # a pass over each (lane numbers)
    import pyarrow.parquet as pq

    ts = pq.read_table(ci_runs / run / "timeseries.parquet", columns=["tank_flow_lps", "pos_enu_x_m"]).to_pydict()
    first = next(i for i, f in enumerate(ts["tank_flow_lps"]) if f > 0)
    assert ts["pos_enu_x_m"][first] < -6.0  # spraying starts over row 1 (x = -7.1 .. -4.7), row 5 is at -3.5 .. -1.1
