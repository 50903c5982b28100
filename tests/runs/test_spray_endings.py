"""Honest endings of spraying runs (real loop, flat world): a job whose battery cannot finish it ends 'aborted',
names the cause and the rows left, and the command exits non-zero; a run cut short is not 'completed'."""

from __future__ import annotations

import json
from pathlib import Path

import yaml
from typer.testing import CliRunner

from vinecli.cli.app import app

ROWS = [[[x, 0.0], [x, 30.0]] for x in (0.0, 3.0, 6.0, 9.0)]


def small_battery_job(d: Path, swap: bool | str) -> Path:
    """x500-sprayer with a 6 Wh pack (~40 s of flight to the reserve) spraying four 30 m rows (~1.6 L) in 1 L
    sorties."""
    veh = yaml.safe_load((Path(__file__).parents[2] / "vehicles" / "x500-sprayer.yaml").read_text())
    veh.update(name="x500-tiny-battery", base=str(Path(__file__).parents[2] / "vehicles" / "x500.yaml"))
    veh["battery"] = {**veh.get("battery", {}), "cells": 4, "capacity_wh": 6.0}
    (d / "tiny.yaml").write_text(yaml.safe_dump(veh))
    m = d / "job.yaml"
    m.write_text(yaml.safe_dump({
        "name": "tiny-job", "vehicle": str(d / "tiny.yaml"), "tank_fill_l": 1.0, "max_duration_s": 400,
        "record_rate_hz": 10,
        "phases": [{"type": "takeoff", "altitude_agl_m": 3.0},
                   {"type": "spray", "rows": ROWS, "height_agl_m": 2.0, "speed_mps": 3.0, "rate_lpha": 50.0,
                    "refill": {"swap_battery": swap, "return_altitude_agl_m": 3.0}, "timeout_s": 390},
                   {"type": "rtl", "return_altitude_agl_m": 3.0}],
    }))
    return m


def test_a_job_the_battery_cannot_finish_is_aborted_and_exits_non_zero(flat_world_dir: Path, tmp_path: Path) -> None:
    m = small_battery_job(tmp_path, False)
    r = CliRunner().invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(tmp_path / "runs")])
    assert r.exit_code == 1, r.output
    s = json.loads((tmp_path / "runs" / "tiny-job-s0" / "summary.json").read_text())
    assert s["status"] == "aborted" and s["passed"] is False
    assert "no battery swap" in s["status_message"] and "not sprayed" in s["status_message"]
    ends = [e for e in map(json.loads, (tmp_path / "runs" / "tiny-job-s0" / "events.jsonl").read_text().splitlines())
            if e["kind"] == "sortie" and e["data"].get("event") == "end"]
    assert ends[0]["data"]["reason"].startswith("battery at")  # the first sortie came home on energy, not empty
    assert ends[-1]["data"].get("last") is True and ends[-1]["data"]["spraying_left_m"] > 10.0
    # the vehicle came down: landed and disarmed at home
    assert s["metrics"]["touchdown_s"] is not None


def test_a_spraying_run_that_sprayed_nothing_is_not_completed_and_rows_carry_the_worlds_numbers() -> None:
    import numpy as np

    from vinecli.runs.spray_report import judge_ending, row_label
    from vinecli.specs.mission import MissionSpec

    spec = MissionSpec.model_validate({"name": "p", "phases": [
        {"type": "takeoff", "altitude_agl_m": 3.0},
        {"type": "spray", "rows": [8], "height_agl_m": 2.0, "speed_mps": 3.0, "rate_lpha": 50.0}, {"type": "land"}]})
    down = {"armed": np.array([1.0, 0.0]), "on_ground": np.array([0.0, 1.0])}
    status, msg = judge_ending("completed", "all phases completed", spec, None, down)  # no deposition at all
    assert status == "aborted" and "nothing was sprayed" in msg
    row = {"row": 0, "world_row": 8, "planned_m": [0.0, 60.0], "covered_fraction": 0.09}
    status, msg = judge_ending("completed", "all phases completed", spec, [row], down)
    assert status == "aborted" and "rows 8 (9%)" in msg
    assert row_label(row) == 8 and row_label({"row": 3, "world_row": None}) == 3


def test_cutouts_are_located_on_the_row_and_so_is_the_place_a_tank_ran_dry() -> None:
    import numpy as np

    from vinecli.runs.spray_report import describe_spray, locate_cutouts

    rows = [{"row": 0, "world_row": 8, "planned_m": [0.0, 60.0], "polyline_enu": [[2.0, 0.0], [2.0, 60.0]]}]
    ts = {"t_s": np.array([10.0, 11.0, 12.0]), "pos_enu_x_m": np.array([2.0, 2.05, 2.1]),
          "pos_enu_y_m": np.array([20.0, 23.0, 26.0])}
    events = [(5.0, "sprayer_cutout", {"reason": "ground speed 0.80 m/s", "position_est_enu": [2.2, 14.0, 2.0]}),
              (7.0, "sprayer_cutout", {"reason": "tank empty", "position_est_enu": [2.0, 75.0, 2.0]}),  # headland
              (11.5, "sortie", {"event": "end", "reason": "tank empty", "last": True, "spraying_left_m": 40.0})]
    cuts = locate_cutouts(events, rows, 1.0, ts)
    assert cuts == [{"t_s": 5.0, "reason": "ground speed 0.80 m/s", "row": 8, "at_m": 14.0},
                    {"t_s": 11.5, "reason": "tank empty", "row": 8, "at_m": 23.0}]
    assert "sprayer cut-out on row 8 at 23.0 m (11.5 s: tank empty)" in describe_spray([], cuts)
