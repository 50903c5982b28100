"""On the commands that came after the first attack (tests/attack/test_attack.py):
``vehicle fit`` / ``vehicle replay``, ``run compare``, ``gis export``, ``plan swath``, ``plan rows`` with its
``OUT-stem.rows.geojson``, ``world build`` with ``gis:`` files, ``report --baseline``, and firmware runs.

One sandbox holds a grower's GIS files and DSM with their world spec, a flight log, a vehicle, a mission, the
built world, a spray run, a vehicle fit and a swath. Every command is aimed at its inputs (the output is,
contains or lies inside one), at another command's folder, at links and folders planted where its files go,
and given values that break naive code: each exits 2 with one line, and afterwards every file of the sandbox
is byte-identical (nothing written, nothing replaced, no temporary left). Then a batch flying real ArduPilot
and PX4 firmware is killed with ``kill -9``: no process of its tree (workers, firmware) is left after 5 s.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import sys
import time
from pathlib import Path

import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "safety"))
from attack_kit import SAMPLE_DSM, cli, error_line, fingerprint, kill_session, vinecli_proc, wait_for  # noqa: E402
from proc_tree import alive, descendants  # noqa: E402
from repo_paths import REPO  # noqa: E402

from tests.flightlog.synthetic_log import synthetic_log  # noqa: E402
from tests.gis.test_gis_world import grower_world  # noqa: E402
from tests.sitl.ardupilot.real_ardupilot import ardupilot_bin  # noqa: E402,F401 - fixture
from tests.sitl.px4.real_px4 import px4_bin  # noqa: E402,F401 - fixture

SPRAY = {"name": "m", "vehicle": "x500-sprayer", "max_duration_s": 60,
         "phases": [{"type": "takeoff", "altitude_agl_m": 2.5},
                    {"type": "spray", "rows": [[[-6.0, -1.0], [6.0, -1.0]]], "height_agl_m": 2.0, "speed_mps": 3.0,
                     "rate_lpha": 60.0},
                    {"type": "land"}]}


@pytest.fixture(scope="module")
def sandbox(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from vinecli.flightlog.ulog_write import write_ulog

    sb = tmp_path_factory.mktemp("attack2")
    grower, specs = sb / "grower", sb / "specs"
    grower.mkdir()
    specs.mkdir()
    grower_world(grower)  # field.tif, rows.gpkg, fence.kml, stream.geojson and w.yaml naming them
    shutil.copy(SAMPLE_DSM, grower / "survey.tif")
    write_ulog(synthetic_log(), sb / "flight.ulg")
    shutil.copy(REPO / "vehicles" / "x500-sprayer.yaml", specs / "myveh.yaml")
    (specs / "m.yaml").write_text(yaml.safe_dump(SPRAY))
    (sb / "fakebin").write_bytes(b"\x7fELF not a firmware\n")
    for args in (["world", "build", grower / "w.yaml", "--out", sb / "world"],
                 ["run", "mission", specs / "m.yaml", "--world", sb / "world", "--out", sb / "runs"],
                 ["vehicle", "fit", sb / "flight.ulg", "--out", sb / "fit", "--mass", "2.0"],
                 ["plan", "swath", "--vehicle", specs / "myveh.yaml", "--out", sb / "swath"]):
        r = cli(*args)
        assert r.exit_code in (0, 1), (args, r.output)  # the spray run's default checks may fail: exit 1
    (sb / "mine.geojson").write_text('{"type": "FeatureCollection", "features": []}\n')  # a user's file
    (sb / "taken.rows.geojson").write_text("a user's rows\n")
    os.symlink(sb / "elsewhere.rows.geojson", sb / "linked.rows.geojson")  # dangling: a write would create it
    os.symlink(sb / "elsewhere.gpkg", sb / "linked.gpkg")
    (sb / "folder.gpkg").mkdir()
    return sb


def _attacks(sb: Path) -> list[list[object]]:
    """Commands that must be refused (exit 2, one line)."""
    g, s, w, run, log = sb / "grower", sb / "specs", sb / "world", sb / "runs" / "m-s0", sb / "flight.ulg"
    return [
        # vehicle fit: the log, a folder holding it, a path inside it, a folder holding its --base, a run
        ["vehicle", "fit", log, "--out", log],
        ["vehicle", "fit", log, "--out", sb, "--overwrite"],
        ["vehicle", "fit", log, "--out", log / "x"],
        ["vehicle", "fit", log, "--out", sb / "fit", "--base", sb / "fit" / "vehicle.yaml", "--overwrite"],
        ["vehicle", "fit", log, "--out", run, "--overwrite"],
        ["vehicle", "fit", log, "--out", sb / "fit2", "--mass", "nan"],
        # vehicle replay: the fit it replays, the vehicle file, the log, another command's folder
        ["vehicle", "replay", log, "--vehicle", sb / "fit" / "vehicle.yaml", "--out", sb / "fit", "--overwrite"],
        ["vehicle", "replay", log, "--vehicle", s / "myveh.yaml", "--out", s / "myveh.yaml"],
        ["vehicle", "replay", log, "--vehicle", "x500", "--out", log, "--overwrite"],
        ["vehicle", "replay", log, "--vehicle", "x500", "--out", sb / "swath", "--overwrite"],
        ["vehicle", "replay", log, "--vehicle", "x500", "--out", sb / "rep", "--window", "inf"],
        # run compare: the world, the mission's folder, the mission, a folder holding the firmware binary
        ["run", "compare", s / "m.yaml", "--world", w, "--out", w, "--autopilots", "builtin,ardupilot",
         "--ardupilot-bin", sb / "fakebin"],
        ["run", "compare", s / "m.yaml", "--world", w, "--out", s, "--autopilots", "builtin,ardupilot",
         "--ardupilot-bin", sb / "fakebin"],
        ["run", "compare", s / "m.yaml", "--world", w, "--out", s / "m.yaml", "--autopilots", "builtin,ardupilot",
         "--ardupilot-bin", sb / "fakebin"],
        ["run", "compare", s / "m.yaml", "--world", w, "--out", sb, "--autopilots", "builtin,ardupilot",
         "--ardupilot-bin", sb / "fakebin"],
        ["run", "compare", s / "m.yaml", "--world", w, "--out", sb / "cmp", "--autopilots", "builtin,builtin"],
        # run mission: a folder holding its firmware binary
        ["run", "mission", s / "m.yaml", "--world", w, "--out", sb, "--run-id", "fakebin", "--overwrite",
         "--autopilot", "ardupilot", "--ardupilot-bin", sb / "fakebin"],
        # gis export: inside the run, the world, a folder, links, a user's file, not a GIS file name
        ["gis", "export", run, "--out", run / "x.gpkg"],
        ["gis", "export", run, "--out", w / "world.json", "--overwrite"],
        ["gis", "export", run, "--out", w / "x.geojson"],
        ["gis", "export", run, "--out", sb / "folder.gpkg", "--overwrite"],
        ["gis", "export", run, "--out", sb / "linked.gpkg"],
        ["gis", "export", run, "--out", sb / "linked.gpkg", "--overwrite"],
        ["gis", "export", run, "--out", sb / "mine.geojson"],
        ["gis", "export", run, "--out", g / "survey.tif", "--overwrite"],
        # plan swath: the vehicle, its folder, a run, values out of range
        ["plan", "swath", "--vehicle", s / "myveh.yaml", "--out", s / "myveh.yaml"],
        ["plan", "swath", "--vehicle", s / "myveh.yaml", "--out", s, "--overwrite"],
        ["plan", "swath", "--out", run, "--overwrite"],
        ["plan", "swath", "--out", sb / "sw", "--height", "nan"],
        ["plan", "swath", "--out", sb / "sw", "--speed", "0"],
        ["plan", "swath", "--out", sb / "sw", "--crosswind", "1e9"],
        # plan rows: the DSM, two outputs at one path, a user's side file, a link where the side file goes
        ["plan", "rows", g / "survey.tif", "--out", g / "survey.tif", "--overwrite"],
        ["plan", "rows", g / "survey.tif", "--out", sb / "a.plan", "--mission", sb / "a.plan"],
        ["plan", "rows", g / "survey.tif", "--out", sb / "a.plan", "--mission", sb / "a.rows.geojson"],
        ["plan", "rows", g / "survey.tif", "--out", sb / "taken.plan"],
        ["plan", "rows", g / "survey.tif", "--out", sb / "linked.plan", "--overwrite"],
        ["plan", "rows", w, "--out", w / "rows.plan"],
        # world build with gis: files: the folder holding them, a GIS file, inside one, a run folder
        ["world", "build", g / "w.yaml", "--out", g, "--overwrite"],
        ["world", "build", g / "w.yaml", "--out", g / "rows.gpkg", "--overwrite"],
        ["world", "build", g / "w.yaml", "--out", g / "fence.kml" / "x"],
        ["world", "build", g / "w.yaml", "--out", run, "--overwrite"],
        # report: its baseline, a folder of another command
        ["report", sb / "runs", "--baseline", sb / "runs", "--out", sb / "runs", "--overwrite"],
        ["report", sb / "runs", "--out", sb / "fit", "--overwrite"],
    ]


def test_every_command_aimed_at_its_inputs_is_refused(sandbox: Path) -> None:
    everything = fingerprint(sandbox)
    for args in _attacks(sandbox):
        r = cli(*args)
        assert r.exit_code == 2, (args, r.output)
        if "Usage:" not in r.stderr:
            error_line(r)  # one line, ``vinecli: error: ...``
        assert fingerprint(sandbox) == everything, args  # nothing written, replaced or left behind


def test_a_link_planted_in_a_compare_folder_is_not_followed(tmp_path: Path) -> None:
    """``run compare`` writes comparison.json/png into a runs folder that may hold a user's link of that name:
    the file replaces the link, the link's target is never written."""
    from vinecli.batch.compare_autopilots import COMPARISON_PNG
    from vinecli.outputs import write_bytes_atomic

    target = tmp_path / "elsewhere.png"
    target.write_bytes(b"mine")
    runs = tmp_path / "runs"
    runs.mkdir()
    os.symlink(target, runs / COMPARISON_PNG)
    with pytest.raises(Exception, match="symbolic link"):
        write_bytes_atomic(runs / COMPARISON_PNG, b"png")
    assert target.read_bytes() == b"mine" and (runs / COMPARISON_PNG).is_symlink()


def test_plan_rows_side_file_is_named_after_the_plan(sandbox: Path, tmp_path: Path) -> None:
    """The rows GeoJSON goes beside the plan as OUT-stem.rows.geojson, never a fixed name; a DSM's inputs stay
    byte-identical."""
    before = fingerprint(sandbox / "grower")
    r = cli("plan", "rows", sandbox / "grower" / "survey.tif", "--out", tmp_path / "job.plan")
    assert r.exit_code == 0, r.output
    assert (tmp_path / "job.rows.geojson").is_file() and not (tmp_path / "rows.geojson").exists()
    assert fingerprint(sandbox / "grower") == before


FIRMWARE_MISSION = {"name": "fw", "vehicle": "x500-sprayer", "max_duration_s": 3600.0, "record_rate_hz": 2.0,
                    "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "hold", "duration_s": 3500.0},
                               {"type": "land"}]}


def _firmware_running(pid: int, name: str) -> bool:
    """A process below ``pid`` runs the executable ``name`` (arducopter, px4)."""
    return any(Path(_comm(c).split(" ", 1)[0]).name == name for c in descendants(pid))


def _comm(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


@pytest.mark.parametrize("firmware", ["ardupilot", "px4"])
def test_kill_9_of_a_batch_flying_firmware_leaves_no_process(request: pytest.FixtureRequest, firmware: str,
                                                             flat_world_dir: Path, tmp_path: Path) -> None:
    binary = request.getfixturevalue(f"{firmware}_bin")
    (tmp_path / "fw.yaml").write_text(yaml.safe_dump(FIRMWARE_MISSION))
    (tmp_path / "p.yaml").write_text(yaml.safe_dump({"name": "p", "world": str(flat_world_dir), "autopilot": firmware,
                                                     "missions": ["fw.yaml"]}))
    batch = vinecli_proc("run", "batch", tmp_path / "p.yaml", "--out", tmp_path / "runs", f"--{firmware}-bin", binary)
    exe = "arducopter" if firmware == "ardupilot" else "px4"
    tree: set[int] = set()
    try:
        assert wait_for(lambda: _firmware_running(batch.pid, exe) or batch.poll() is not None, 180), "no firmware"
        assert batch.poll() is None, batch.stderr.read() if batch.stderr else ""
        time.sleep(2.0)  # booting or flying
        tree = descendants(batch.pid)
        os.kill(batch.pid, signal.SIGKILL)
        t0 = time.monotonic()
        batch.wait(timeout=10)
        gone = wait_for(lambda: not any(alive(p) for p in tree), timeout=5.0, every=0.05)
        left = [(p, _comm(p)[:80]) for p in tree if alive(p)]
        assert gone, f"left {time.monotonic() - t0:.1f} s after kill -9: {left}"
        print(f"{firmware}: no process left {time.monotonic() - t0:.2f} s after kill -9 of the batch")
    finally:
        for p in tree | descendants(batch.pid):
            with contextlib.suppress(ProcessLookupError):
                os.kill(p, signal.SIGKILL)
        kill_session(batch)
