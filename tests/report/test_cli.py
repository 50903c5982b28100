"""``vinecli report``: exit codes (0 / 1 / 2), the report path, bad inputs naming the run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from vinecli.cli.app import app

runner = CliRunner()


def report(*args: object):
    return runner.invoke(app, ["report", *[str(a) for a in args]])


def one_error_line(r) -> str:
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("vinecli: error:")
    return " ".join(lines[0].split())


def test_passing_batch_exits_0_and_prints_the_report(ci_runs: Path, tmp_path: Path) -> None:
    out = tmp_path / "rep"
    r = report(ci_runs, "--out", out, "--format", "md,json,junit")
    assert r.exit_code == 0, r.stderr
    assert "4 runs: 4 passed, 0 failed, 0 errors" in r.stdout
    assert (out / "summary.md").is_file() and not (out / "report.html").exists()


def test_html_path_is_printed(ci_runs: Path, tmp_path: Path) -> None:
    out = tmp_path / "rep"
    r = report(ci_runs, "--out", out, "--figures", "none", "--format", "html")
    assert r.exit_code == 0, r.stderr
    assert f"report: {(out / 'report.html').resolve()}" in " ".join(r.stdout.split())


def test_failing_check_exits_1(failing_runs: Path, tmp_path: Path) -> None:
    out = tmp_path / "rep"
    r = report(failing_runs, "--out", out, "--figures", "none")
    assert r.exit_code == 1
    assert "1 check(s) failed" in one_error_line(r)
    assert "holds_position" in (out / "summary.md").read_text()
    assert "holds_position" in (out / "junit.xml").read_text()


def test_regression_exits_1_and_tolerance_clears_it(ci_runs: Path, drifting_runs: Path, tmp_path: Path) -> None:
    r = report(drifting_runs, "--out", tmp_path / "a", "--baseline", ci_runs, "--format", "json")
    assert r.exit_code == 1 and "regression" in one_error_line(r)
    r = report(drifting_runs, "--out", tmp_path / "b", "--baseline", ci_runs, "--format", "json",
               "--tolerance", "hpos_error_max_m=1", "--tolerance", "max_tilt_deg=10")
    assert r.exit_code == 0, r.stderr


def test_existing_output_needs_overwrite(ci_runs: Path, tmp_path: Path) -> None:
    out = tmp_path / "rep"
    assert report(ci_runs, "--out", out, "--format", "json").exit_code == 0
    r = report(ci_runs, "--out", out, "--format", "json")
    assert r.exit_code == 2 and "--overwrite" in one_error_line(r)
    assert report(ci_runs, "--out", out, "--format", "json", "--overwrite").exit_code == 0


# ---------------------------------------------------------------- bad inputs -> exit 2 naming the run
def _corrupt_summary(d: Path) -> None:
    (d / "spray" / "summary.json").write_text("{not json")


def _summary_without_checks(d: Path) -> None:
    s = json.loads((d / "spray" / "summary.json").read_text())
    del s["checks"]
    (d / "spray" / "summary.json").write_text(json.dumps(s))


def _missing_timeseries(d: Path) -> None:
    (d / "spray" / "timeseries.parquet").unlink()


def _corrupt_parquet(d: Path) -> None:
    (d / "spray" / "timeseries.parquet").write_bytes(b"PAR1 this is not parquet")


def _corrupt_events(d: Path) -> None:
    with open(d / "spray" / "events.jsonl", "a") as f:
        f.write("{oops\n")


def _missing_run_dir(d: Path) -> None:
    import shutil

    shutil.rmtree(d / "spray")


@pytest.mark.parametrize(("damage", "problem"), [
    (_corrupt_summary, "unreadable summary.json"),
    (_summary_without_checks, "lacks checks"),
    (_missing_timeseries, "missing timeseries.parquet"),
    (_corrupt_parquet, "cannot read timeseries.parquet"),
    (_corrupt_events, "events.jsonl line"),
    (_missing_run_dir, "listed in batch.json is missing"),
])
def test_bad_run_exits_2_naming_the_run(runs_copy: Path, tmp_path: Path, damage, problem: str) -> None:
    damage(runs_copy)
    out = tmp_path / "rep"
    r = report(runs_copy, "--out", out)
    assert r.exit_code == 2
    line = one_error_line(r)
    assert str(runs_copy / "spray") in line and problem in line
    assert not out.exists()  # nothing half-written


def test_not_a_runs_directory(tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    r = report(tmp_path / "empty", "--out", tmp_path / "rep")
    assert r.exit_code == 2 and "not a runs directory" in one_error_line(r)
    r = report(tmp_path / "nope", "--out", tmp_path / "rep")
    assert r.exit_code == 2 and str(tmp_path / "nope") in one_error_line(r)


def test_corrupt_batch_json(runs_copy: Path, tmp_path: Path) -> None:
    (runs_copy / "batch.json").write_text('{"cases": 3}')
    r = report(runs_copy, "--out", tmp_path / "rep")
    assert r.exit_code == 2 and "batch.json" in one_error_line(r)


def test_bad_options(ci_runs: Path, tmp_path: Path) -> None:
    r = report(ci_runs, "--out", tmp_path / "a", "--format", "html,pdf")
    assert r.exit_code == 2 and "pdf" in one_error_line(r)
    r = report(ci_runs, "--out", tmp_path / "b", "--tolerance", "hpos_error_max_m")
    assert r.exit_code == 2 and "NAME=ABS" in one_error_line(r)
    r = report(ci_runs, "--out", tmp_path / "c", "--figures", "some")
    assert r.exit_code == 2 and "--figures" in one_error_line(r)
    r = report(ci_runs, "--out", tmp_path / "d", "--baseline", tmp_path / "missing")
    assert r.exit_code == 2 and str(tmp_path / "missing") in one_error_line(r)


def test_single_run_directory_and_plain_runs_dir(ci_runs: Path, tmp_path: Path) -> None:
    r = report(ci_runs / "takeoff", "--out", tmp_path / "one", "--format", "json")
    assert r.exit_code == 0, r.stderr
    assert json.loads((tmp_path / "one" / "summary.json").read_text())["totals"]["runs"] == 1
    import shutil

    plain = tmp_path / "plain"
    shutil.copytree(ci_runs, plain)
    (plain / "batch.json").unlink()
    # a previous report placed inside the runs directory is not mistaken for a run
    assert report(plain, "--out", plain / "report", "--format", "json").exit_code == 0
    r = report(plain, "--out", tmp_path / "again", "--format", "json")
    assert r.exit_code == 0, r.stderr
    assert json.loads((tmp_path / "again" / "summary.json").read_text())["totals"]["runs"] == 4
