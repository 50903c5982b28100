"""Autopilots side by side (vinecli.runs.compare, vinecli.report.autopilots): dose figures against hand
arithmetic, grouping by mission and seed, the table, figure and report section. What these check is the
bookkeeping and the rendering, not any autopilot: the runs are synthetic run directories of
tests/report/synth_runs.py (real deposition model), the second one a copy of the first filed under another
autopilot name and firmware ("other", "Test 0.0"), so both columns hold the same figures by construction.
The real three-way comparison (built-in, PX4 and ArduPilot flying pipelines/missions/spray-two-rows.yaml,
the dose of each row judged) is tests/sitl/test_three_way.py, which needs ../shared."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.report.synth_runs import write_run
from vinecli.report import build_report, load_runs
from vinecli.report.autopilots import comparison_groups, comparison_png, markdown_table
from vinecli.runs.compare import compare_runs, dose_figures


def test_hot_spots_and_gaps_are_shares_of_row_length(tmp_path: Path) -> None:
    run = tmp_path / "r"
    run.mkdir()
    rows = [{"row": 0, "length_m": 1.8, "segment_m": 0.5, "rate_lpha": [10.0, 20.0, 50.0, 5.0],  # last segment 0.3 m
             "mean_rate_lpha": 21.0, "covered_fraction": 0.5},
            {"row": 1, "length_m": 1.0, "segment_m": 0.5, "rate_lpha": [20.0, 41.0], "mean_rate_lpha": 30.5,
             "covered_fraction": 1.0}]
    (run / "deposition.json").write_text(json.dumps({"metrics": {"nominal_rate_lpha": 20.0}, "rows": rows}))
    d = dose_figures(run)
    assert d["hot_spot_fraction"] == pytest.approx((0.5 + 0.5) / 2.8)  # 50 and 41 > 2 x 20
    assert d["gap_fraction"] == pytest.approx(0.3 / 2.8)  # 5 < 0.5 x 20 (10 is not below 10)
    assert [r["mean_rate_lpha"] for r in d["rows"]] == [21.0, 30.5]
    assert dose_figures(tmp_path)["hot_spot_fraction"] is None  # no deposition: no dose figures


@pytest.fixture
def two_autopilots(tmp_path: Path) -> Path:
    """A built-in run and its copy filed as flown by autopilot "other" (firmware "Test 0.0"), plus a run of
    another mission by one autopilot only."""
    runs = tmp_path / "runs"
    import shutil

    builtin = write_run(runs, "spray", run_id="spray-builtin", seed=0)
    other = runs / "spray-other"
    shutil.copytree(builtin, other)
    s = json.loads((other / "summary.json").read_text())
    s["autopilot"], s["run_id"], s["case"] = "other", "spray-other", "spray-other"
    s["firmware"] = {"firmware": "Test", "version": "0.0", "git_hash": "00000000", "files": []}
    (other / "summary.json").write_text(json.dumps(s))
    write_run(runs, "gust", run_id="gust-builtin", seed=0)  # one autopilot only: not compared
    return runs


def test_runs_of_one_mission_and_seed_are_compared(two_autopilots: Path, tmp_path: Path) -> None:
    groups = comparison_groups(load_runs(two_autopilots))
    assert len(groups) == 1
    cmp = groups[0]
    assert cmp["mission"] == "spray" and cmp["seed"] == 0
    by = {r["autopilot"]: r for r in cmp["runs"]}
    assert by["other"]["firmware"] == "Test 0.0" and by["builtin"]["firmware"] == "vinecli built-in"
    assert {k: v for k, v in by["other"].items() if k not in ("run_id", "dir", "autopilot", "firmware", "behaviour")} == \
        {k: v for k, v in by["builtin"].items() if k not in ("run_id", "dir", "autopilot", "firmware", "behaviour")}  # a copy
    s = json.loads((two_autopilots / "spray-builtin" / "summary.json").read_text())
    assert by["builtin"]["energy_wh"] == s["metrics"].get("energy_wh")
    assert by["builtin"]["tracking_error_m"] == pytest.approx(s["metrics"]["cross_track_rms_m"])
    assert by["builtin"]["row_coverage_fraction"] == pytest.approx(s["metrics"]["row_coverage_fraction"])
    assert 0.0 <= by["builtin"]["gap_fraction"] <= 1.0 and len(by["builtin"]["rows"]) == 6
    md = markdown_table(cmp)
    assert "other (Test 0.0)" in md and "target 5 dose (vs asked), covered" in md  # its mission.yaml lists no rows and "| dose checks |" in md
    png = comparison_png(cmp)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000
    assert compare_runs([two_autopilots / "spray-builtin"])["runs"][0]["autopilot"] == "builtin"


def test_the_report_shows_the_comparison(two_autopilots: Path, tmp_path: Path) -> None:
    build_report(two_autopilots, tmp_path / "rep", formats="html,md,json", figures="none")
    assert "## Autopilots side by side" in (tmp_path / "rep" / "summary.md").read_text()
    html = (tmp_path / "rep" / "report.html").read_text()
    assert "Autopilots side by side" in html and "figA" in html
    doc = json.loads((tmp_path / "rep" / "summary.json").read_text())
    assert len(doc["autopilots"]) == 1 and len(doc["autopilots"][0]["runs"]) == 2
