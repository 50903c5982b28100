"""Names cannot become paths, every write stays inside ``--out``, ``--out`` never replaces
an input, ``run mission`` needs ``--overwrite`` to replace a run, outputs follow the umask, writability is
probed before the work. Real worlds, the real loop, real run and report directories."""

from __future__ import annotations

import os
import shutil
import stat
from pathlib import Path

import pytest
from repo_paths import REPO
from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.errors import OutputError
from vinecli.names import check_name, name_from, name_problem
from vinecli.outputs import Manifest, atomic_output_dir, check_output_target, contained_path

runner = CliRunner()

MISSION = """\
name: {name}
vehicle: x500-sprayer
tank_fill_l: 0.5
max_duration_s: 20
record_rate_hz: 25
phases:
  - {{type: takeoff, altitude_agl_m: 1.5}}
  - {{type: land}}
"""


def one_error_line(r) -> str:
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("vinecli: error:")
    return " ".join(lines[0].split())


def tree(root: Path) -> set[str]:
    return {p.relative_to(root).as_posix() for p in root.rglob("*")}


@pytest.mark.parametrize("bad", ["../escaped", "/tmp/abs", "a/b", "..", ".hidden", "-rf", "a\x1bb", "tab\tx",
                                 "", "x" * 200])
def test_unsafe_names_are_refused(bad: str) -> None:
    assert name_problem(bad) is not None
    with pytest.raises(Exception) as exc:
        check_name(bad, "run id")
    assert getattr(exc.value, "exit_code", None) == 2


@pytest.mark.parametrize("good", ["takeoff", "gust-strong", "gust-1a2b3c4d-s123", "x500_sprayer", "v1.2+rc"])
def test_safe_names_pass(good: str) -> None:
    assert check_name(good) == good


@pytest.mark.parametrize(("text", "name"), [("my plan", "my_plan"), ("../../x", "_._x"), ("..", "mission"),
                                           (".hidden", "hidden"), ("", "mission"), ("ok-1.2", "ok-1.2")])
def test_names_derived_from_file_names_are_safe(text: str, name: str) -> None:
    assert name_from(text) == name and name_problem(name_from(text)) is None


def test_contained_path_refuses_escapes(tmp_path: Path) -> None:
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "link").symlink_to(tmp_path)
    assert contained_path(tmp_path / "out", "a", "b.html") == tmp_path / "out" / "a" / "b.html"
    for parts in (("..", "x"), ("/etc",), ("link", "x"), (".",)):
        with pytest.raises(OutputError):
            contained_path(tmp_path / "out", *parts)


@pytest.mark.parametrize("run_id", ["../escaped", "/tmp/vinecli-abs-run", "a\nb"])
def test_run_id_outside_out_is_refused(flat_world_dir: Path, tmp_path: Path, run_id: str) -> None:
    m = tmp_path / "m.yaml"
    m.write_text(MISSION.format(name="quick"))
    before = tree(tmp_path)
    r = runner.invoke(app, ["run", "mission", str(m), "-w", str(flat_world_dir), "--out", str(tmp_path / "runs"),
                            "--run-id", run_id])
    assert r.exit_code == 2, r.output
    assert "run id" in one_error_line(r)
    assert tree(tmp_path) == before
    assert not Path("/tmp/vinecli-abs-run").exists()


def test_mission_name_with_a_path_is_refused(flat_world_dir: Path, tmp_path: Path) -> None:
    victim = tmp_path / "victim-s0"
    victim.mkdir()
    (victim / "keep.txt").write_text("precious")
    m = tmp_path / "m.yaml"
    m.write_text(MISSION.format(name="../victim"))
    r = runner.invoke(app, ["run", "mission", str(m), "-w", str(flat_world_dir), "--out", str(tmp_path / "runs")])
    assert r.exit_code == 2
    assert "name" in one_error_line(r) and str(m) in one_error_line(r)
    assert (victim / "keep.txt").read_text() == "precious"


def test_pipeline_case_name_with_a_path_is_refused(flat_world_dir: Path, tmp_path: Path) -> None:
    (tmp_path / "m.yaml").write_text(MISSION.format(name="quick"))
    p = tmp_path / "p.yaml"
    p.write_text(f"name: p\nworld: {flat_world_dir}\nmissions: [{{mission: m.yaml, name: ../../evil}}]\n")
    r = runner.invoke(app, ["run", "batch", str(p), "--out", str(tmp_path / "runs")])
    assert r.exit_code == 2
    assert "missions.0.name" in one_error_line(r)
    assert not (tmp_path / "runs").exists()


def test_run_mission_refuses_an_existing_run_without_overwrite(flat_world_dir: Path, tmp_path: Path) -> None:
    m = tmp_path / "m.yaml"
    m.write_text(MISSION.format(name="quick"))
    args = ["run", "mission", str(m), "-w", str(flat_world_dir), "--out", str(tmp_path / "runs")]
    assert runner.invoke(app, args).exit_code in (0, 1)
    first = (tmp_path / "runs" / "quick-s0" / "summary.json").read_bytes()
    r = runner.invoke(app, args)
    assert r.exit_code == 2 and "--overwrite" in one_error_line(r)
    assert (tmp_path / "runs" / "quick-s0" / "summary.json").read_bytes() == first
    assert runner.invoke(app, [*args, "--overwrite"]).exit_code in (0, 1)


def test_world_build_out_containing_the_spec_is_refused(tmp_path: Path) -> None:
    d = tmp_path / "d"
    d.mkdir()
    shutil.copy(REPO / "worlds" / "flat.yaml", d / "w.yaml")
    r = runner.invoke(app, ["world", "build", str(d / "w.yaml"), "--out", str(d), "--overwrite"])
    assert r.exit_code == 2 and "input" in one_error_line(r)
    assert (d / "w.yaml").is_file()


def test_report_out_equal_to_runs_is_refused(tmp_path: Path) -> None:
    from tests.report.synth_runs import write_ci_batch

    runs = write_ci_batch(tmp_path / "runs")
    before = tree(runs)
    r = runner.invoke(app, ["report", str(runs), "--out", str(runs), "--overwrite", "--format", "json"])
    assert r.exit_code == 2 and "input" in one_error_line(r)
    r = runner.invoke(app, ["report", str(runs), "--out", str(tmp_path), "--overwrite", "--format", "json"])
    assert r.exit_code == 2 and "input" in one_error_line(r)
    assert tree(runs) == before


def test_report_unwritable_out_fails_before_reading_the_runs(tmp_path: Path) -> None:
    """The output is probed first: a missing runs directory is not even looked at."""
    if os.geteuid() == 0:
        out = Path("/proc/vinecli-no/report")  # read-only even for root
    else:
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o500)
        out = ro / "report"
    r = runner.invoke(app, ["report", str(tmp_path / "no-such-runs"), "--out", str(out)])
    assert r.exit_code == 2
    assert "not writable" in one_error_line(r) and "no-such-runs" not in one_error_line(r)


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_outputs_follow_the_umask(tmp_path: Path, umask: int) -> None:
    old = os.umask(umask)
    try:
        with atomic_output_dir(tmp_path / "out", Manifest(command="test")) as tmp:
            (tmp / "sub").mkdir()
            (tmp / "f.txt").write_text("x")
    finally:
        os.umask(old)
    for p, full in ((tmp_path / "out", 0o777), (tmp_path / "out" / "sub", 0o777), (tmp_path / "out" / "f.txt", 0o666)):
        assert stat.S_IMODE(p.stat().st_mode) == full & ~umask, p


def test_check_output_target_refuses_inputs(tmp_path: Path) -> None:
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "a.yaml").write_text("x: 1\n")
    for out in (tmp_path / "in", tmp_path):
        with pytest.raises(OutputError, match="input"):
            check_output_target(out, overwrite=True, inputs=[tmp_path / "in" / "a.yaml"])
    check_output_target(tmp_path / "in" / "report", inputs=[tmp_path / "in" / "a.yaml"])


def test_batch_case_dir_never_replaces_its_mission(flat_world_dir: Path, tmp_path: Path) -> None:
    """A case named like the folder holding its mission, with --out at the pipeline: the batch is refused at
    load (every case's folder is checked against every input before anything is written), the
    mission survives."""
    (tmp_path / "missions").mkdir()
    (tmp_path / "missions" / "m.yaml").write_text(MISSION.format(name="quick"))
    p = tmp_path / "p.yaml"
    p.write_text(f"name: p\nworld: {flat_world_dir}\nmissions: [{{mission: missions/m.yaml, name: missions}}]\n")
    r = runner.invoke(app, ["run", "batch", str(p), "--out", str(tmp_path)])
    assert r.exit_code == 2 and "input" in r.stderr and "m.yaml" in r.stderr
    assert (tmp_path / "missions" / "m.yaml").read_text() == MISSION.format(name="quick")
    assert not (tmp_path / "batch.json").exists()
