"""An attack on one sandbox, as a careless or hostile user would try it.

The sandbox holds every kind of input (a DSM, a point cloud, a world spec and its base, a vehicle and its
base, a built world, missions with a ``base:`` chain, a pipeline, a .plan, a finished runs folder). Then:

* every command's outputs are aimed at its inputs: the output is, contains or lies inside an input;
* user folders and symbolic links are planted in ``--out`` (named like a case, as ``_worlds``, as ``--out``);
* two writers of one run id run at once;
* a running batch is killed with ``kill -9``.

After all of it: every input is byte-identical, nothing was written outside the output folders the
commands were given, and no process of the killed batch is left.
"""

from __future__ import annotations

import os
import shutil
import signal
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "safety"))
from attack_kit import IDLE, PLAN, SAMPLE_DSM, cli, fingerprint, kill_session, mission, vinecli_proc, wait_for  # noqa: E402
from proc_tree import alive, descendants, simulating  # noqa: E402
from repo_paths import REPO, TEST_DATA  # noqa: E402

VEHICLES = REPO / "vehicles"


@pytest.fixture(scope="module")
def sandbox(tmp_path_factory: pytest.TempPathFactory, flat_world_dir: Path) -> Path:
    sb = tmp_path_factory.mktemp("attack")
    data, specs = sb / "data", sb / "specs"
    data.mkdir()
    specs.mkdir()
    shutil.copy(TEST_DATA / "pysheds_dem_3arcsec_epsg4326_int16.tif", data / "dem.tif")  # geographic CRS
    shutil.copy(SAMPLE_DSM, data / "field.tif")
    shutil.copy(TEST_DATA / "lidr_topography_als.laz", data / "cloud.laz")
    shutil.copy(PLAN, data / "job.plan")
    for name in ("x500-sprayer.yaml", "x500.yaml"):
        shutil.copy(VEHICLES / name, specs / name)
    (specs / "worldbase.yaml").write_text("origin: {lat: 32.67, lon: -97.33, alt: 200.0}\nvehicle: x500-sprayer.yaml\n")
    (specs / "w.yaml").write_text("name: w\nbase: worldbase.yaml\n"
                                  "terrain: {type: dsm, path: ../data/dem.tif, format: heightmap, size: 65}\n")
    mission(specs, "quick")
    (specs / "child.yaml").write_text("base: quick.yaml\nname: child\nvehicle: x500-sprayer.yaml\n")
    mission(specs, "idle", text=IDLE)
    shutil.copytree(flat_world_dir, sb / "world")
    (specs / "p.yaml").write_text("name: p\nworld: ../world\nmissions: [child.yaml]\n")
    (specs / "pw.yaml").write_text("name: pw\nworld: w.yaml\nmissions: [child.yaml]\n")
    (specs / "pidle.yaml").write_text("name: pidle\nworld: ../world\n"
                                      "missions: [idle.yaml, {mission: idle.yaml, name: idle2}]\n")
    r = cli("run", "batch", specs / "p.yaml", "--out", sb / "runs")
    assert r.exit_code in (0, 1), r.output
    return sb


def _attacks(sb: Path) -> list[list[object]]:
    """Commands whose output is, contains or lies inside one of their inputs (each must exit 2)."""
    d, s, w, runs = sb / "data", sb / "specs", sb / "world", sb / "runs"
    return [
        ["terrain", "convert", d / "dem.tif", "--to", "heightmap", "--out", d / "dem.tif"],
        ["terrain", "convert", d / "dem.tif", "--to", "heightmap", "--out", d, "--overwrite"],
        ["terrain", "convert", d / "dem.tif", "--to", "tiles", "--out", sb, "--overwrite"],
        ["terrain", "reconstruct", d / "cloud.laz", "--out", d / "cloud.laz"],
        ["terrain", "reconstruct", d / "cloud.laz", "--out", d, "--overwrite"],
        ["world", "build", s / "w.yaml", "--out", s, "--overwrite"],  # the spec, its base, the vehicle
        ["world", "build", s / "w.yaml", "--out", d, "--overwrite"],  # the DSM it names
        ["world", "build", s / "w.yaml", "--out", d / "dem.tif" / "x"],
        ["run", "mission", s / "child.yaml", "--world", w, "--out", w],  # the run would lie inside the world
        ["run", "mission", s / "child.yaml", "--world", w, "--out", sb, "--run-id", "specs", "--overwrite"],
        ["run", "batch", s / "p.yaml", "--out", w],
        ["run", "batch", s / "p.yaml", "--out", s / "p.yaml"],
        ["report", runs, "--out", runs, "--overwrite"],
        ["report", runs, "--out", sb, "--overwrite"],
        ["report", runs, "--out", runs / "child" / "r"],
        ["plan", "rows", d / "field.tif", "--out", d / "field.tif"],
        ["plan", "rows", d / "field.tif", "--out", sb / "rows.plan", "--mission", d / "field.tif", "--overwrite"],
        ["plan", "rows", w, "--out", w / "world.json", "--overwrite"],
        ["plan", "import", d / "job.plan", "--world", w, "--out", d / "job.plan", "--overwrite"],
        ["plan", "import", d / "job.plan", "--world", w, "--out", w / "world.json", "--overwrite"],
        ["plan", "import", d / "job.plan", "--world", w, "--out", s / "quick.yaml"],  # a user file, no --overwrite
    ]


def test_attack(sandbox: Path, tmp_path: Path) -> None:
    sb = sandbox
    inputs = fingerprint(sb / "data", sb / "specs", sb / "world")
    everything = fingerprint(sb)
    # 1. outputs aimed at inputs: refused, one line each, nothing written anywhere
    for args in _attacks(sb):
        r = cli(*args)
        assert r.exit_code == 2, (args, r.output)
        assert fingerprint(sb) == everything, args
    # 2. user folders and links planted in --out: named and kept
    out = tmp_path / "out"
    (out / "child").mkdir(parents=True)
    (out / "child" / "notes.txt").write_text("mine\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    os.symlink(elsewhere, out / "_worlds")
    planted = fingerprint(out, elsewhere)
    for args in (["run", "batch", sb / "specs" / "p.yaml", "--out", out],
                 ["run", "batch", sb / "specs" / "pw.yaml", "--out", out],
                 ["run", "mission", sb / "specs" / "child.yaml", "--world", sb / "world", "--out", out,
                  "--run-id", "child", "--overwrite"],
                 ["world", "build", sb / "specs" / "w.yaml", "--out", out / "_worlds", "--overwrite"]):
        r = cli(*args)
        assert r.exit_code == 2, (args, r.output)
    assert fingerprint(out, elsewhere) == planted
    # 3. two writers of one run id at once: the second is refused at once, the first writes its run
    idle, runs2 = sb / "specs" / "idle.yaml", tmp_path / "runs2"
    first = vinecli_proc("run", "mission", idle, "--world", sb / "world", "--out", runs2)
    try:
        assert wait_for(lambda: (runs2 / ".idle-s0.lock").exists() or first.poll() is not None)
        second = vinecli_proc("run", "mission", idle, "--world", sb / "world", "--out", runs2, "--overwrite")
        assert second.wait(timeout=120) == 2
        first.send_signal(signal.SIGTERM)
        assert first.wait(timeout=120) == 143 and (runs2 / "idle-s0" / "summary.json").is_file()
    finally:
        kill_session(first)
    # 4. kill -9 of a running batch: no process left within 5 s
    batch = vinecli_proc("run", "batch", sb / "specs" / "pidle.yaml", "--out", tmp_path / "runs3", "--workers", "2")
    try:
        assert wait_for(lambda: sum(map(simulating, descendants(batch.pid))) >= 2 or batch.poll() is not None, 180)
        tree = descendants(batch.pid)
        os.kill(batch.pid, signal.SIGKILL)
        t0 = time.monotonic()
        batch.wait(timeout=10)
        assert wait_for(lambda: not any(alive(p) for p in tree), timeout=5.0), "processes outlived the batch"
        print(f"kill -9: no process left after {time.monotonic() - t0:.2f} s")
    finally:
        kill_session(batch)
    # after all of it: the inputs are byte-identical and nothing was written into the sandbox
    assert fingerprint(sb / "data", sb / "specs", sb / "world") == inputs
    assert fingerprint(sb) == everything
