"""No temporary file or folder is left after any ending, and a failed command leaves no
folder it made.

* Scratch folders in the system's temporary directory are named after their owner (pid and start time); every
  vinecli start removes those of owners that are gone, and never another program's or a live vinecli's.
* A firmware that fails early (exits at once, dies of a signal, never connects, speaks garbage) leaves no
  scratch folder, its error message names files that exist in the run folder, and ``summary.json`` lists them
  (``close()`` acts once: its record is not replaced by an empty one).
* A PX4 binary without its ``etc/`` is refused (exit 2) before any folder is made.
* ``kill -9`` of a firmware run leaves its scratch folder, its instance lock and its run's lock; the next vinecli
  start removes them all (the killed process had listed its output folders in the temporary directory).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from attack_kit import cli, error_line, kill_session, wait_for
from repo_paths import REPO

from vinecli.lifeline import owner_tag, start_ticks
from vinecli.outputs import remove_stale_temps
from vinecli.scratch import scratch_dir, sweep_scratch

TAKEOFF = {"name": "m", "vehicle": "x500-sprayer", "max_duration_s": 30.0,
           "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "land"}]}


def _dead_owner() -> str:
    """``PID.START`` of a process that has ended."""
    p = subprocess.Popen(["true"])
    tag = owner_tag(p.pid)
    p.wait()
    return tag


def test_the_sweep_removes_only_what_gone_owners_left(tmp_path: Path) -> None:
    dead, me = _dead_owner(), owner_tag()
    for name in (f"vinecli-px4-{dead}-abc123", f"vinecli-firmware-{dead}-x_1", f"vinecli-ardupilot-{me}-live1",
                 "vinecli-px4-10-1n84dujv", "vinecli-firmware-2zxkt5n9", f"other-{dead}-abc", "vinecli-px4"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "px4.log").write_text("x")
    (tmp_path / f"vinecli-px4-{dead}-afile").write_text("a file, not a folder vinecli made")
    removed = sorted(p.name for p in sweep_scratch(tmp_path))
    assert removed == [f"vinecli-firmware-{dead}-x_1", f"vinecli-px4-{dead}-abc123"]
    left = sorted(p.name for p in tmp_path.iterdir())
    assert f"vinecli-ardupilot-{me}-live1" in left and "vinecli-px4-10-1n84dujv" in left  # live; older name
    assert "vinecli-firmware-2zxkt5n9" in left and f"other-{dead}-abc" in left and "vinecli-px4" in left


def test_a_reused_pid_is_another_owner(tmp_path: Path) -> None:
    """The pid alone is not the owner: a folder whose pid now names a process started at another time is swept."""
    other_start = (start_ticks(os.getpid()) or 0) + 12345
    (tmp_path / f"vinecli-px4-{os.getppid()}.{other_start}-abc").mkdir()
    assert [p.name for p in sweep_scratch(tmp_path)] == [f"vinecli-px4-{os.getppid()}.{other_start}-abc"]


def test_scratch_folders_carry_their_owner(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    d = scratch_dir("px4")
    assert d.parent == tmp_path and d.name.startswith(f"vinecli-px4-{owner_tag()}-")
    assert sweep_scratch(tmp_path) == [] and d.is_dir()  # its owner (this process) is alive


def test_out_folder_sweep_keeps_a_user_s_files_and_live_writers(tmp_path: Path) -> None:
    dead, me = _dead_owner(), owner_tag()
    names = {f".run.tmp-{dead}-ab12cd34": "dir", f".x.gpkg.tmp-{dead}-ab12cd34.gpkg": "file",
             f".y.tmp-{me}-ab12cd34": "dir", ".notes.tmp-999999-abc": "file", ".editor.lock": "file"}
    for name, kind in names.items():
        (tmp_path / name).mkdir() if kind == "dir" else (tmp_path / name).write_text("12345\n")
    removed = sorted(p.name for p in remove_stale_temps(tmp_path))
    assert removed == [f".run.tmp-{dead}-ab12cd34", f".x.gpkg.tmp-{dead}-ab12cd34.gpkg"]
    # a live writer's, a name without vinecli's owner stamp, a lock file that is not vinecli's: kept
    assert {f".y.tmp-{me}-ab12cd34", ".notes.tmp-999999-abc", ".editor.lock"} <= {p.name for p in tmp_path.iterdir()}


# ---------------------------------------------------------------- firmware that fails early (fake binaries)
FAKE_PX4 = {
    "exits at once": "#!/bin/sh\necho 'px4 says: no airframe'\nexit 3\n",
    "segfaults": "#!/bin/sh\necho 'px4 says: boom'\nkill -SEGV $$\n",
    "never connects": "#!/bin/sh\necho 'px4 says: waiting'\nexec sleep 600\n",
    "speaks garbage": f"#!{sys.executable}\n" + """import socket, sys, time
i = int(sys.argv[sys.argv.index("-i") + 1])
print("px4 says: garbage", flush=True)
s = socket.create_connection(("127.0.0.1", 4560 + i), timeout=10)
for _ in range(200):
    s.sendall(bytes(range(256)) * 8)
    time.sleep(0.05)
""",
}


def _fake_px4(root: Path, script: str, etc: bool = True) -> Path:
    (root / "bin").mkdir(parents=True)
    if etc:
        (root / "etc" / "init.d-posix").mkdir(parents=True)
        (root / "etc" / "init.d-posix" / "rcS").write_text("")
    b = root / "bin" / "px4"
    b.write_text(script)
    b.chmod(0o755)
    return b


def _vinecli(*args: object, tmpdir: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "TMPDIR": str(tmpdir), "COLUMNS": "200",
           "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run([sys.executable, "-m", "vinecli", *map(str, args)], env=env, capture_output=True, text=True,
                          timeout=timeout)


@pytest.mark.parametrize("case", list(FAKE_PX4))
def test_a_px4_that_fails_early_leaves_no_scratch_and_points_to_files_that_exist(
        case: str, flat_world_dir: Path, tmp_path: Path) -> None:
    px4 = _fake_px4(tmp_path / "px4", FAKE_PX4[case])
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(TAKEOFF))
    wait = "2" if case == "never connects" else "5"  # the one that can only end by the timeout: a shorter one
    r = _vinecli("run", "mission", tmp_path / "m.yaml", "--world", flat_world_dir, "--out", tmp_path / "runs",
                 "--autopilot", "px4", "--px4-bin", px4, "--px4-connect-timeout", wait, tmpdir=tmpdir)
    assert r.returncode == 3, r.stderr
    assert [p.name for p in tmpdir.iterdir() if p.name.startswith("vinecli-") and "." in p.name] == [], case
    run = tmp_path / "runs" / "m-s0"
    summary = json.loads((run / "summary.json").read_text())
    files = summary["firmware"]["files"]
    assert "firmware/px4.log" in files and all((run / f).is_file() for f in files), files
    assert "px4 says" in (run / "firmware" / "px4.log").read_text()
    if "firmware/px4.log in the run folder" in r.stderr:
        assert (run / "firmware" / "px4.log").is_file()


def test_a_px4_without_its_etc_is_refused_before_any_folder_is_made(flat_world_dir: Path, tmp_path: Path) -> None:
    px4 = _fake_px4(tmp_path / "px4", FAKE_PX4["exits at once"], etc=False)
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(TAKEOFF))
    before = set(Path(os.environ.get("TMPDIR", "/tmp")).glob(f"vinecli-px4-{owner_tag()}-*"))
    r = cli("run", "mission", tmp_path / "m.yaml", "--world", flat_world_dir, "--out", tmp_path / "runs",
            "--autopilot", "px4", "--px4-bin", px4)
    assert r.exit_code == 2 and "no SITL start-up files" in error_line(r)
    assert set(Path(os.environ.get("TMPDIR", "/tmp")).glob(f"vinecli-px4-{owner_tag()}-*")) == before
    assert not (tmp_path / "runs").exists()  # class 8: the runs folder it would have made is not left either


@pytest.mark.parametrize("what", ["a directory", "a FIFO"])
def test_a_firmware_binary_that_is_not_a_file_is_named_for_what_it_is(what: str, flat_world_dir: Path,
                                                                        tmp_path: Path) -> None:
    b = tmp_path / "arducopter"
    b.mkdir() if what == "a directory" else os.mkfifo(b)
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(TAKEOFF))
    r = cli("run", "mission", tmp_path / "m.yaml", "--world", flat_world_dir, "--out", tmp_path / "runs",
            "--autopilot", "ardupilot", "--ardupilot-bin", b)
    assert r.exit_code == 2 and f"is {what}, not a regular file" in error_line(r)


def test_kill_9_leaves_a_scratch_folder_and_a_lock_that_the_next_vinecli_removes(flat_world_dir: Path,
                                                                                tmp_path: Path) -> None:
    px4 = _fake_px4(tmp_path / "px4", FAKE_PX4["never connects"])
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(TAKEOFF))
    env = {**os.environ, "TMPDIR": str(tmpdir), "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    runs = tmp_path / "runs"
    proc = subprocess.Popen([sys.executable, "-m", "vinecli", "run", "mission", str(tmp_path / "m.yaml"), "--world",
                             str(flat_world_dir), "--out", str(runs), "--autopilot", "px4", "--px4-bin", str(px4)],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        assert wait_for(lambda: any(tmpdir.glob("vinecli-px4-*")) and (runs / ".m-s0.lock").exists(), 120)
        time.sleep(0.5)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        kill_session(proc)
    assert any(tmpdir.glob("vinecli-px4-*")) and (runs / ".m-s0.lock").exists()  # what kill -9 leaves
    assert any(tmpdir.glob("vinecli-outputs-*.list")) and any(tmpdir.glob("vinecli-px4/instance-*.lock"))
    r = _vinecli("--version", tmpdir=tmpdir)  # any start sweeps what a killed vinecli left, here and in its --out
    assert r.returncode == 0 and list(tmpdir.iterdir()) == [], list(tmpdir.iterdir())
    assert not (runs / ".m-s0.lock").exists()
    (tmp_path / "m2.yaml").write_text(yaml.safe_dump({**TAKEOFF, "name": "m2"}))
    r = _vinecli("run", "mission", tmp_path / "m2.yaml", "--world", flat_world_dir, "--out", runs, tmpdir=tmpdir)
    assert r.returncode in (0, 1), r.stderr
    assert list(tmpdir.iterdir()) == []  # a normal end removes its own list
