"""Atomic and locked. A second writer of a run id (or of a batch folder) exits 2 at once,
``in use by pid N``, instead of racing (on main both runs of one id exited 0 and one was lost); a lock
left by a dead process is taken over; nothing but complete runs lands in ``--out``. Real processes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

from attack_kit import IDLE, cli, kill_session, mission, vinecli_proc, wait_for

from vinecli.outputs import manifest_problem


def _started(runs: Path, run_id: str) -> bool:
    return (runs / f".{run_id}.lock").is_file()


def test_a_second_writer_of_a_run_id_exits_2_naming_the_first(flat_world_dir: Path, tmp_path: Path) -> None:
    m = mission(tmp_path, "idle", text=IDLE)
    runs = tmp_path / "runs"
    first = vinecli_proc("run", "mission", m, "--world", flat_world_dir, "--out", runs, "--overwrite")
    try:
        assert wait_for(lambda: _started(runs, "idle-s0") or first.poll() is not None), "the first run never started"
        assert first.poll() is None, first.stderr.read() if first.stderr else ""
        second = vinecli_proc("run", "mission", m, "--world", flat_world_dir, "--out", runs, "--overwrite")
        _out, err = second.communicate(timeout=120)
        assert second.returncode == 2, err
        assert f"in use by pid {first.pid}" in " ".join(err.split())
        first.send_signal(signal.SIGTERM)  # the first run stops and is written (interrupted), untouched by the second
        first.wait(timeout=120)
        assert first.returncode == 143
        assert manifest_problem(runs / "idle-s0") is None
        assert json.loads((runs / "idle-s0" / "summary.json").read_text())["status"] == "interrupted"
    finally:
        kill_session(first)


def test_a_second_batch_on_one_folder_exits_2(flat_world_dir: Path, tmp_path: Path) -> None:
    mission(tmp_path, "idle", text=IDLE)
    p = tmp_path / "p.yaml"
    p.write_text(f"name: p\nworld: {flat_world_dir}\nmissions: [idle.yaml]\n")
    runs = tmp_path / "runs"
    first = vinecli_proc("run", "batch", p, "--out", runs)
    try:
        assert wait_for(lambda: (runs / ".vinecli.lock").is_file() or first.poll() is not None)
        assert first.poll() is None
        second = vinecli_proc("run", "batch", p, "--out", runs)
        _out, err = second.communicate(timeout=120)
        assert second.returncode == 2, err
        assert f"in use by pid {first.pid}" in " ".join(err.split())
    finally:
        kill_session(first)


def test_a_lock_left_by_a_dead_process_is_taken_over(flat_world_dir: Path, tmp_path: Path) -> None:
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    runs = tmp_path / "runs"
    runs.mkdir()
    (runs / ".m-s0.lock").write_text(f"{dead.pid}\n")  # a run killed with -9 left its lock file
    m = mission(tmp_path, "m")
    r = cli("run", "mission", m, "--world", flat_world_dir, "--out", runs)
    assert r.exit_code in (0, 1), r.output
    assert manifest_problem(runs / "m-s0") is None
    assert not (runs / ".m-s0.lock").exists()  # released and removed


def test_a_lock_held_by_a_live_process_names_it(flat_world_dir: Path, tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    runs.mkdir()
    lock = runs / ".m-s0.lock"
    holder = subprocess.Popen([sys.executable, "-c", (
        "import fcntl, os, sys, time\n"
        f"fd = os.open({str(lock)!r}, os.O_RDWR | os.O_CREAT)\n"
        "fcntl.flock(fd, fcntl.LOCK_EX)\n"
        "os.write(fd, str(os.getpid()).encode())\n"
        "print('locked', flush=True)\n"
        "time.sleep(120)\n")], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "locked"
        m = mission(tmp_path, "m")
        r = cli("run", "mission", m, "--world", flat_world_dir, "--out", runs)
        assert r.exit_code == 2, r.output
        assert f"in use by pid {holder.pid}" in " ".join(r.stderr.split())
        assert not (runs / "m-s0").exists()
    finally:
        holder.kill()
        holder.wait()
    assert os.path.exists(lock)  # a lock file of a live holder is never removed
