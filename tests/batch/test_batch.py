"""Batch runner: pipeline expansion, seeds, local process pool, errors, crashes, timeouts, resume, Dask."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from vinecli.batch import run_batch
from vinecli.batch.pipeline import derive_seed, expand_cases, load_pipeline
from vinecli.errors import SpecError

from ._batch_cases import case_light

MISSION = """\
name: {name}
vehicle: x500-sprayer
tank_fill_l: 1.0
wind: {{law: {{type: sinusoid, mean_mps: 2.0, amplitude_mps: 1.0, period_s: 8.0}}}}
phases:
  - {{type: takeoff, altitude_agl_m: 3.0}}
  - {{type: hold, duration_s: 2.0}}
checks:
  - {{name: alt, quantity: pos_enu_z_m, reduce: max, op: ">", bound: 1.0}}
"""


@pytest.fixture()
def pipe_dir(tmp_path: Path) -> Path:
    (tmp_path / "missions").mkdir()
    for name in ("hover", "boom", "crash", "hang", "ok2"):
        (tmp_path / "missions" / f"{name}.yaml").write_text(MISSION.format(name=name))
    world = tmp_path / "world"
    world.mkdir()
    (world / "world.json").write_text("{}")
    return tmp_path


def write_pipe(d: Path, body: str) -> Path:
    p = d / "pipe.yaml"
    p.write_text("name: test\nworld: world\n" + body)
    return p


def test_expand_sweep_names_and_seeds_are_stable(pipe_dir: Path) -> None:
    p = write_pipe(pipe_dir, """\
seed: 7
missions: [missions/hover.yaml]
sweep:
  mission: missions/hover.yaml
  matrix: {wind.law.amplitude_mps: [1.0, 2.5], tank_fill_l: [0.5, 1.0]}
  seeds: 2
""")
    cases = expand_cases(load_pipeline(p), p)
    assert len(cases) == 1 + 2 * 2 * 2
    assert cases[0].name == "hover" and cases[0].seed == derive_seed(7, "hover")
    sweep = cases[1:]
    assert len({c.name for c in sweep}) == 8
    amps = sorted({c.mission["wind"]["law"]["amplitude_mps"] for c in sweep})
    assert amps == [1.0, 2.5]
    assert {c.mission["tank_fill_l"] for c in sweep} == {0.5, 1.0}
    for c in sweep:
        assert c.name.startswith("hover-") and c.name.endswith(f"-s{c.seed}")
    again = expand_cases(load_pipeline(p), p)
    assert [(c.name, c.seed) for c in again] == [(c.name, c.seed) for c in cases]
    # a different root seed changes the seeds, not the parameter hashes
    p2 = write_pipe(pipe_dir, p.read_text().split("\n", 2)[2].replace("seed: 7", "seed: 8"))
    other = expand_cases(load_pipeline(p2), p2)
    assert other[1].seed != cases[1].seed
    assert other[1].name.rsplit("-s", 1)[0] == cases[1].name.rsplit("-s", 1)[0]


def test_seed_axis_and_explicit_seed(pipe_dir: Path) -> None:
    p = write_pipe(pipe_dir, """\
missions:
  - {mission: missions/hover.yaml, name: h42, seed: 42}
sweep:
  mission: missions/hover.yaml
  matrix: {seed: [1, 2], vehicle: [x500-sprayer, hex-sprayer]}
""")
    cases = expand_cases(load_pipeline(p), p)
    assert cases[0].name == "h42" and cases[0].seed == 42
    assert sorted(c.seed for c in cases[1:]) == [1, 1, 2, 2]
    assert {c.mission["vehicle"] for c in cases[1:]} == {"x500-sprayer", "hex-sprayer"}


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        ("missions: [missions/nope.yaml]\n", "nope.yaml"),
        ("sweep: {mission: missions/hover.yaml, matrix: {max_duration_s: [-1]}}\n", "max_duration_s"),
        ("missions: [missions/hover.yaml, missions/hover.yaml]\n", "duplicate case name"),
        ("missions: [{mission: missions/hover.yaml, wrld: x}]\n", "wrld"),
        ("description: nothing to run\n", "missions"),
    ],
)
def test_bad_pipelines(pipe_dir: Path, body: str, needle: str) -> None:
    p = write_pipe(pipe_dir, body)
    with pytest.raises(SpecError) as ei:
        expand_cases(load_pipeline(p), p)
    assert needle in str(ei.value) and "pipe.yaml" in str(ei.value)


def test_local_pool_error_crash_and_resume(pipe_dir: Path, tmp_path: Path) -> None:
    p = write_pipe(pipe_dir, """\
missions: [missions/hover.yaml, missions/boom.yaml, missions/crash.yaml, missions/ok2.yaml]
""")
    runs = tmp_path / "runs"
    seen: list[tuple[str, int]] = []
    res = run_batch(p, runs, workers=2, run_case=case_light, progress=lambda r, d, n: seen.append((r.case, n)))
    by = {c.case: c for c in res.cases}
    assert by["hover"].passed and by["ok2"].passed
    assert by["boom"].status == "error" and "exploded" in by["boom"].error
    assert by["crash"].status == "error" and "crashed" in by["crash"].error
    assert res.n_errors == 2 and not res.passed
    assert sorted(c for c, _ in seen) == ["boom", "crash", "hover", "ok2"] and all(n == 4 for _, n in seen)
    batch = json.loads((runs / "batch.json").read_text())
    assert [c["case"] for c in batch["cases"]] == ["hover", "boom", "crash", "ok2"]
    assert batch["cases"][1]["error"] and batch["pipeline"] == "test"
    # spawned workers, not the test process
    pid = json.loads((runs / "hover" / "summary.json").read_text())["pid"]
    assert pid != os.getpid()
    # resume: finished cases are skipped, the others run again
    mtime = (runs / "hover" / "summary.json").stat().st_mtime_ns
    res2 = run_batch(p, runs, workers=1, run_case=case_light, resume=True)
    by2 = {c.case: c for c in res2.cases}
    assert by2["hover"].skipped and by2["ok2"].skipped and not by2["boom"].skipped
    assert (runs / "hover" / "summary.json").stat().st_mtime_ns == mtime


def test_hanging_case_is_killed_and_batch_goes_on(pipe_dir: Path, tmp_path: Path) -> None:
    p = write_pipe(pipe_dir, "missions: [missions/hang.yaml, missions/hover.yaml, missions/ok2.yaml]\n")
    res = run_batch(p, tmp_path / "runs", workers=2, run_case=case_light, timeout_s=1.0, grace_s=2.0)
    by = {c.case: c for c in res.cases}
    assert by["hang"].status == "error" and "timeout" in by["hang"].error
    assert by["hover"].passed and by["ok2"].passed


def test_dask_local_cluster_same_code_path(pipe_dir: Path, tmp_path: Path) -> None:
    p = write_pipe(pipe_dir, "missions: [missions/hover.yaml, missions/boom.yaml, missions/ok2.yaml]\n")
    res = run_batch(p, tmp_path / "runs", workers=1, executor="dask", run_case=case_light, dask_processes=False)
    by = {c.case: c for c in res.cases}
    assert by["hover"].passed and by["ok2"].passed
    assert by["boom"].status == "error" and "exploded" in by["boom"].error
    assert json.loads((tmp_path / "runs" / "batch.json").read_text())["executor"] == "dask"


def test_shipped_pipelines_expand() -> None:
    from repo_paths import REPO

    ci = REPO / "pipelines" / "ci.yaml"
    cases = expand_cases(load_pipeline(ci), ci)
    assert [c.name for c in cases] == ["takeoff", "overload", "spray", "gust", "job"]
    assert all(c.world.endswith("vineyard-sample.yaml") for c in cases)
    sw = REPO / "pipelines" / "sweep-wind-fill.yaml"
    cases = expand_cases(load_pipeline(sw), sw)
    assert len(cases) == 3 * 2 * 2 * 2 and len({c.name for c in cases}) == 24
    assert {c.mission["vehicle"] for c in cases} == {"x500-sprayer", "hex-sprayer"}


def test_dask_scheduler_address(pipe_dir: Path, tmp_path: Path) -> None:
    """--scheduler: connect to an existing Dask scheduler instead of starting a cluster."""
    from dask.distributed import LocalCluster

    p = write_pipe(pipe_dir, "missions: [missions/hover.yaml, missions/ok2.yaml]\n")
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        res = run_batch(p, tmp_path / "runs", workers=1, executor="dask", scheduler=cluster.scheduler_address,
                        run_case=case_light)
    assert res.passed and len(res.cases) == 2


def test_bad_executor_options(pipe_dir: Path, tmp_path: Path) -> None:
    from vinecli.errors import InputError

    p = write_pipe(pipe_dir, "missions: [missions/hover.yaml]\n")
    with pytest.raises(InputError, match="unknown executor"):
        run_batch(p, tmp_path / "r", executor="ray")
    with pytest.raises(InputError, match="--scheduler needs --executor dask"):
        run_batch(p, tmp_path / "r", scheduler="tcp://127.0.0.1:1")
    with pytest.raises(InputError, match="--workers"):
        run_batch(p, tmp_path / "r", workers=0)


def test_world_override(pipe_dir: Path, tmp_path: Path) -> None:
    other = tmp_path / "other_world"
    other.mkdir()
    (other / "world.json").write_text("{}")
    p = write_pipe(pipe_dir, "missions: [missions/hover.yaml, {mission: missions/ok2.yaml, world: world}]\n")
    runs = tmp_path / "runs"
    run_batch(p, runs, workers=1, run_case=case_light, world=other)
    assert json.loads((runs / "hover" / "summary.json").read_text())["world_dir"] == str(other.resolve())
    assert json.loads((runs / "ok2" / "summary.json").read_text())["world_dir"] == str((pipe_dir / "world").resolve())


def test_world_as_a_sweep_axis(pipe_dir: Path, tmp_path: Path) -> None:
    other = pipe_dir / "world2"
    other.mkdir()
    (other / "world.json").write_text("{}")
    p = write_pipe(pipe_dir, "sweep: {mission: missions/hover.yaml, matrix: {world: [world, world2]}, seeds: 1}\n")
    cases = expand_cases(load_pipeline(p), p)
    assert [Path(c.world).name for c in cases] == ["world", "world2"]
    assert cases[0].name != cases[1].name
    res = run_batch(p, tmp_path / "runs", workers=1, run_case=case_light)
    dirs = {json.loads((tmp_path / "runs" / c.run_id / "summary.json").read_text())["world_dir"] for c in res.cases}
    assert dirs == {str((pipe_dir / "world").resolve()), str(other.resolve())}


def test_batch_counts_keep_interrupted_cases_apart() -> None:
    """passed / failed checks / could not run / interrupted are disjoint: an interrupted case (partial run, or
    never started) is neither a check failure nor an error, so the CLI can say which it was."""
    from vinecli.batch.case import CaseResult
    from vinecli.batch.run import BatchResult

    cases = [CaseResult("a", "a", "completed", True), CaseResult("b", "b", "completed", False),
             CaseResult("c", "c", "error", False, "timeout: no result"),
             CaseResult("d", "d", "interrupted", False), CaseResult("e", "e", "interrupted", False, "not run: stopped")]
    r = BatchResult("p", "runs", cases)
    assert (r.n_passed, r.n_failed, r.n_errors, r.n_interrupted) == (1, 1, 1, 2)
    assert r.n_passed + r.n_failed + r.n_errors + r.n_interrupted == len(cases)
