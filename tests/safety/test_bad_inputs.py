"""Exit 2 for every bad input. Each kind the attack pass found ending in exit 3 (or hanging)
on main now ends with one clear line and exit 2, nothing written; a FIFO is refused without blocking."""

from __future__ import annotations

import os
import shutil
import threading
from pathlib import Path

import pytest
from attack_kit import PLAN, cli, error_line, fingerprint, mission
from repo_paths import REPO, TEST_DATA


def _pipeline(d: Path, world: Path, body: str) -> Path:
    mission(d, "base")
    p = d / "p.yaml"
    p.write_text(f"name: p\nworld: {world}\n{body}")
    return p


@pytest.mark.parametrize(("body", "what"), [
    ("sweep: {mission: base.yaml, matrix: {seed: [abc]}}\n", "seed"),  # non-numeric sweep value
    ("sweep: {mission: base.yaml, matrix: {seed: [.nan]}}\n", "seed"),  # NaN
    ("sweep: {mission: base.yaml, matrix: {seed: [1e400]}}\n", "seed"),  # huge
    ("sweep: {mission: base.yaml, matrix: {seed: [18446744073709551616]}}\n", "seed"),  # beyond the seed range
    ("sweep: {mission: base.yaml, matrix: {world: [7]}}\n", "world"),  # a number where a path belongs
    ("seed: 18446744073709551616\nmissions: [base.yaml]\n", "seed"),  # root seed: 2**64 would fold onto 0
    ("missions: [{mission: base.yaml, seed: 4294967295, seeds: 2}]\n", "seed"),  # replicates beyond the range
    ("missions: [{mission: base.yaml, name: batch.json}]\n", "batch.json"),  # a case named like a file we write
    ("missions: [{mission: base.yaml, name: _worlds}]\n", "_worlds"),
])
def test_bad_pipelines_exit_2_before_anything_runs(flat_world_dir: Path, tmp_path: Path, body: str, what: str) -> None:
    p = _pipeline(tmp_path, flat_world_dir, body)
    r = cli("run", "batch", p, "--out", tmp_path / "runs")
    assert r.exit_code == 2, r.output
    assert what in error_line(r)
    assert not (tmp_path / "runs" / "batch.json").exists()


@pytest.mark.parametrize("seed", ["-1", str(2**64)])
def test_run_seeds_outside_the_range_exit_2(flat_world_dir: Path, tmp_path: Path, seed: str) -> None:
    r = cli("run", "mission", mission(tmp_path), "--world", flat_world_dir, "--out", tmp_path / "runs", "--seed", seed)
    assert r.exit_code == 2, r.output
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize(("spec", "field"), [
    ("origin: {lat: 47.0, lon: 8.0, alt: 50000}\nterrain: {type: flat}\n", "origin.alt"),
    ("origin: {lat: 47.0, lon: 8.0, alt: 0}\nterrain: {type: flat}\n"
     "geofence: {max_altitude_agl_m: 60000, polygon_enu: [[-9, -9], [9, -9], [9, 9], [-9, 9]]}\n", "geofence"),
])
def test_altitudes_of_tens_of_kilometres_exit_2(tmp_path: Path, spec: str, field: str) -> None:
    (tmp_path / "w.yaml").write_text("name: high\n" + spec)
    r = cli("world", "build", tmp_path / "w.yaml", "--out", tmp_path / "w")
    assert r.exit_code == 2, r.output
    assert field in error_line(r)
    assert not (tmp_path / "w").exists()


@pytest.mark.parametrize("phase", ["{type: takeoff, altitude_agl_m: 50000}",
                                   "{type: waypoints, waypoints: [[0, 0, 30000]]}",
                                   "{type: spray, rows: [[[0, 0], [5, 0]]], height_agl_m: 20000, flow_lps: 0.01}"])
def test_mission_altitudes_of_tens_of_kilometres_exit_2(flat_world_dir: Path, tmp_path: Path, phase: str) -> None:
    (tmp_path / "m.yaml").write_text(f"name: m\nvehicle: x500-sprayer\nphases:\n  - {phase}\n")
    r = cli("run", "mission", tmp_path / "m.yaml", "--world", flat_world_dir, "--out", tmp_path / "runs")
    assert r.exit_code == 2, r.output
    assert not (tmp_path / "runs").exists()


def test_a_world_flown_tens_of_kilometres_up_has_a_real_atmosphere() -> None:
    """A vehicle that climbs for hours leaves the troposphere: the barometer model stays real and invertible
    (on main the pressure went complex above 44 km: exit 3 in the loop)."""
    from vinecli.flight.atmosphere import altitude_at, pressure_at, temperature_at

    for h in (0.0, 5000.0, 11000.0, 30000.0, 60000.0, 100000.0):
        p = pressure_at(h)
        assert isinstance(p, float) and p > 0.0 and temperature_at(h) > 200.0
        assert altitude_at(p) == pytest.approx(h, abs=1e-6 * max(h, 1.0))


def _fifo_args(kind: str, d: Path, world: Path) -> list[object]:
    fifo = d / {"mission": "m.yaml", "plan": "p.plan", "dsm": "d.tif", "world.json": "w/world.json",
                "base": "b.yaml"}[kind]
    fifo.parent.mkdir(exist_ok=True)
    os.mkfifo(fifo)
    if kind == "mission":
        return ["run", "mission", fifo, "--world", world, "--out", d / "runs"]
    if kind == "plan":
        return ["plan", "import", fifo, "--world", world, "--out", d / "m.yaml"]
    if kind == "dsm":
        return ["plan", "rows", fifo, "--out", d / "rows.plan"]
    if kind == "world.json":
        return ["run", "mission", mission(d), "--world", fifo.parent, "--out", d / "runs"]
    (d / "c.yaml").write_text("name: c\nbase: b.yaml\nphases: [{type: land}]\n")
    return ["run", "mission", d / "c.yaml", "--world", world, "--out", d / "runs"]


@pytest.mark.parametrize("kind", ["mission", "plan", "dsm", "world.json", "base"])
def test_a_fifo_given_as_input_is_refused_without_blocking(flat_world_dir: Path, tmp_path: Path, kind: str) -> None:
    args = _fifo_args(kind, tmp_path, flat_world_dir)
    result: list[object] = []
    t = threading.Thread(target=lambda: result.append(cli(*args)), daemon=True)
    t.start()
    t.join(timeout=60)
    if t.is_alive():  # on main `plan import` blocked on the FIFO: unblock it so the test process can end
        fifo = next(p for p in tmp_path.rglob("*") if p.is_fifo())
        with open(fifo, "w"):
            pass
        t.join(timeout=30)
        pytest.fail(f"{kind}: blocked on the FIFO")
    r = result[0]
    assert r.exit_code == 2, r.output  # type: ignore[attr-defined]
    assert "FIFO" in error_line(r)


def test_a_tile_step_of_2_px_exits_2(tmp_path: Path) -> None:
    dsm = TEST_DATA / "lidr_dtm_1m_float64_nocrs.tif"
    r = cli("terrain", "convert", dsm, "--to", "tiles", "--tile-px", "2", "--out", tmp_path / "t")
    assert r.exit_code == 2, r.output
    assert "--tile-px" in error_line(r)
    sample = REPO / "worlds" / "sample" / "fieldimager_potato_plots_dsm_3cm_utm16n.tif"  # 608 x 2193 px
    r = cli("terrain", "convert", sample, "--to", "tiles", "--tile-px", "8", "--out", tmp_path / "t")
    assert r.exit_code == 2, r.output  # 8 px is allowed, but not into 20,000 tiles
    assert "tiles" in error_line(r) and not (tmp_path / "t").exists()


@pytest.mark.parametrize("cut", [0.02, 0.3, 0.6, 0.95])
def test_a_truncated_geotiff_exits_2(tmp_path: Path, cut: float) -> None:
    data = (REPO / "worlds" / "sample" / "fieldimager_potato_plots_dsm_3cm_utm16n.tif").read_bytes()
    bad = tmp_path / "cut.tif"
    bad.write_bytes(data[: int(len(data) * cut)])
    for args in (["terrain", "info", bad], ["plan", "rows", bad, "--out", tmp_path / "r.plan"],
                 ["terrain", "convert", bad, "--to", "heightmap", "--size", "65", "--out", tmp_path / "h"]):
        r = cli(*args)
        assert r.exit_code == 2, (args, r.output)
        assert "cut.tif" in error_line(r)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.tif"]


def test_a_corrupt_world_json_exits_2(flat_world_dir: Path, tmp_path: Path) -> None:
    world = tmp_path / "w"
    shutil.copytree(flat_world_dir, world)
    for text in ('["a list where a mapping belongs"]', '{"schema": "vinecli.world/1", "terrain": []}',
                 '{"schema": "vinecli.world/1", "vehicle": {"spec": {}, "urdf": "/etc/passwd"}}'):
        (world / "world.json").write_text(text)
        r = cli("run", "mission", mission(tmp_path), "--world", world, "--out", tmp_path / "runs")
        assert r.exit_code == 2, (text, r.output)
        assert "world.json" in error_line(r)


def test_a_plan_of_the_wrong_shape_exits_2(flat_world_dir: Path, tmp_path: Path) -> None:
    p = tmp_path / "p.plan"
    p.write_text('{"fileType": "Plan", "mission": []}')
    before = fingerprint(tmp_path)
    r = cli("plan", "import", p, "--world", flat_world_dir, "--out", tmp_path / "m.yaml")
    assert r.exit_code == 2, r.output
    assert fingerprint(tmp_path) == before
    shutil.copy(PLAN, p)  # the real plan imports
