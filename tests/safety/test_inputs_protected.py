"""One notion of inputs. Every command resolves every file it reads (the mission and its
``base:`` chain, the vehicle and its parts, the world folder, the DSM, the .plan) before it writes, and
refuses with exit 2, one line naming both paths and nothing written, an output that is, contains or lies
inside one of them. On main `plan rows` and `plan import` wrote over their own inputs and exited 0, and
``--overwrite`` deleted a run folder holding the run's own indirect inputs."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from attack_kit import PLAN, SAMPLE_DSM, cli, error_line, fingerprint, mission
from repo_paths import REPO

VEHICLES = REPO / "vehicles"


def test_plan_rows_does_not_write_over_its_dsm(tmp_path: Path) -> None:
    dsm = tmp_path / "field.tif"
    shutil.copy(SAMPLE_DSM, dsm)
    before = fingerprint(tmp_path)
    r = cli("plan", "rows", dsm, "--out", dsm)
    assert r.exit_code == 2, r.output
    line = error_line(r)
    assert line.count("field.tif") >= 2 and "input" in line  # both paths: the output and the input it is
    assert fingerprint(tmp_path) == before  # nothing written, the DSM byte-identical


@pytest.mark.parametrize("target", ["world.json", "rows.plan"])
def test_plan_rows_does_not_write_into_its_world(rows_world: Path, tmp_path: Path, target: str) -> None:
    world = tmp_path / "world"
    shutil.copytree(rows_world, world)
    before = fingerprint(tmp_path)
    r = cli("plan", "rows", world, "--out", world / target)
    assert r.exit_code == 2, r.output
    assert "world" in error_line(r)
    assert fingerprint(tmp_path) == before


def test_plan_rows_mission_output_is_checked_before_anything_is_written(rows_world: Path, tmp_path: Path) -> None:
    world = tmp_path / "world"
    shutil.copytree(rows_world, world)
    before = fingerprint(tmp_path)
    r = cli("plan", "rows", world, "--out", tmp_path / "rows.plan", "--mission", world / "world.json")
    assert r.exit_code == 2, r.output
    assert fingerprint(tmp_path) == before  # rows.plan was not written first


def test_a_user_rows_geojson_beside_the_plan_is_kept(rows_world: Path, tmp_path: Path) -> None:
    (tmp_path / "rows.geojson").write_text('{"mine": true}\n')
    before = fingerprint(tmp_path / "rows.geojson")
    r = cli("plan", "rows", rows_world, "--out", tmp_path / "rows.plan")
    assert r.exit_code in (0, 2), r.output
    assert fingerprint(tmp_path / "rows.geojson") == before  # kept: named (exit 2) or never touched


@pytest.mark.parametrize("target", ["plan", "world"])
def test_plan_import_does_not_write_over_its_inputs(rows_world: Path, tmp_path: Path, target: str) -> None:
    plan = tmp_path / "job.plan"
    shutil.copy(PLAN, plan)
    world = tmp_path / "world"
    shutil.copytree(rows_world, world)
    before = fingerprint(tmp_path)
    out = plan if target == "plan" else world / "world.json"
    r = cli("plan", "import", plan, "--world", world, "--out", out)
    assert r.exit_code == 2, r.output
    line = error_line(r)
    assert out.name in line and "input" in line and ("job.plan" if target == "plan" else "world") in line
    assert fingerprint(tmp_path) == before


def _run_dir_holding(kind: str, tmp: Path, world: Path) -> tuple[Path, list[str], Path]:
    """A finished run folder runs/m-s0 and, inside it, a file the next run of the same id reads (its mission's
    base or its vehicle's base): the mission file, and the run's extra options."""
    runs = tmp / "runs"
    m = mission(tmp, "m")
    assert cli("run", "mission", m, "--world", world, "--out", runs).exit_code in (0, 1)
    run = runs / "m-s0"
    extra: list[str] = []
    if kind == "mission base":
        (run / "b.yaml").write_text("name: b\nvehicle: x500-sprayer\nphases: [{type: land}]\n")
        m.write_text(m.read_text().replace("name: m\n", "name: m\nbase: runs/m-s0/b.yaml\n"))
    elif kind == "vehicle base":
        for name, text in (("vbase.yaml", (VEHICLES / "x500-sprayer.yaml").read_text()),
                           ("x500.yaml", (VEHICLES / "x500.yaml").read_text())):  # the sprayer's own base
            (run / name).write_text(text)
        (tmp / "v.yaml").write_text("base: runs/m-s0/vbase.yaml\nname: myveh\n")
        m.write_text(m.read_text().replace("vehicle: x500-sprayer", "vehicle: v.yaml"))
    return m, extra, run


@pytest.mark.parametrize("kind", ["mission base", "vehicle base"])
def test_overwrite_keeps_a_run_folder_holding_the_runs_own_inputs(flat_world_dir: Path, tmp_path: Path,
                                                                   kind: str) -> None:
    m, extra, run = _run_dir_holding(kind, tmp_path, flat_world_dir)
    before = fingerprint(run)
    args = ["run", "mission", m, "--world", flat_world_dir, "--out", tmp_path / "runs", "--overwrite", *extra]
    r = cli(*args)
    assert r.exit_code == 2, r.output
    assert "input" in error_line(r) and "m-s0" in error_line(r)
    assert fingerprint(run) == before


def test_a_batch_keeps_a_case_folder_holding_a_world_part(flat_world_dir: Path, tmp_path: Path) -> None:
    """The pipeline's world spec names a vehicle file that lives in a case's folder from an earlier batch:
    building the world reads it, the case would replace the folder. Refused at load, the file kept."""
    runs = tmp_path / "runs"
    m = mission(tmp_path, "quick")
    (tmp_path / "p.yaml").write_text(f"name: p\nworld: {flat_world_dir}\nmissions: [quick.yaml]\n")
    assert cli("run", "batch", tmp_path / "p.yaml", "--out", runs).exit_code in (0, 1)
    for name in ("x500-sprayer.yaml", "x500.yaml"):
        shutil.copy(VEHICLES / name, runs / "quick" / name)
    (tmp_path / "w.yaml").write_text((REPO / "worlds" / "flat.yaml").read_text().replace(
        "vehicle: x500-sprayer", "vehicle: runs/quick/x500-sprayer.yaml"))
    (tmp_path / "p2.yaml").write_text("name: p2\nworld: w.yaml\nmissions: [quick.yaml]\n")
    before = fingerprint(runs / "quick")
    r = cli("run", "batch", tmp_path / "p2.yaml", "--out", runs)
    assert r.exit_code == 2, r.output
    line = error_line(r)
    assert "quick" in line and "x500-sprayer.yaml" in line and "input" in line
    assert fingerprint(runs / "quick") == before
    assert m.is_file()
