"""No orphans. ``kill -9`` of the batch process leaves no process of its tree (fork server,
workers) within 5 s (on main they kept running: the workers ignored SIGTERM and held the fork server up),
and a second signal during the shutdown leaves only complete runs or runs clearly marked as not complete
(batch.json says ``interrupted``), never a half-written folder. Real processes, real signals."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from attack_kit import IDLE, kill_session, mission, vinecli_proc, wait_for
from proc_tree import alive, descendants, simulating
from repo_paths import REPO

#: the longest a killed batch's processes may outlive it, s
DEADLINE_S = 5.0


def _batch_tree(proc: subprocess.Popen[str], n_workers: int) -> set[int]:
    """The batch's processes once ``n_workers`` workers run a case."""
    ok = wait_for(lambda: len({w for w in descendants(proc.pid) if simulating(w)}) >= n_workers
                  or proc.poll() is not None, timeout=180)
    assert ok and proc.poll() is None, proc.stderr.read() if proc.stderr else ""
    time.sleep(1.0)  # into the simulation
    return descendants(proc.pid)


def test_kill_9_of_the_batch_leaves_no_process(flat_world_dir: Path, tmp_path: Path) -> None:
    for name in ("a", "b"):
        mission(tmp_path, name, text=IDLE)
    p = tmp_path / "p.yaml"
    p.write_text(f"name: p\nworld: {flat_world_dir}\nmissions: [a.yaml, b.yaml]\n")
    proc = vinecli_proc("run", "batch", p, "--out", tmp_path / "runs", "--workers", "2")
    try:
        tree = _batch_tree(proc, 2)
        assert len(tree) >= 3  # the fork server and two workers at least
        os.kill(proc.pid, signal.SIGKILL)
        t0 = time.monotonic()
        proc.wait(timeout=10)
        gone = wait_for(lambda: not any(alive(c) for c in tree), timeout=30, every=0.05)
        took = time.monotonic() - t0
        left = [c for c in tree if alive(c)]
        assert gone and took <= DEADLINE_S, f"processes left {took:.1f} s after kill -9: {left}"
        print(f"no process left {took:.2f} s after kill -9 of the batch")
    finally:
        for c in descendants(proc.pid):
            with __import__("contextlib").suppress(ProcessLookupError):
                os.kill(c, signal.SIGKILL)
        kill_session(proc)


SECOND_SIGNAL = """
import sys
sys.path.insert(0, {kit!r})
from attack_cases import case_slow_write
from vinecli.batch import run_batch
if __name__ == "__main__":
    run_batch({pipeline!r}, {runs!r}, workers=2, run_case=case_slow_write)
"""


def test_a_second_signal_during_shutdown_leaves_no_half_written_folder(flat_world_dir: Path, tmp_path: Path) -> None:
    for name in ("a", "b", "c"):
        mission(tmp_path, name)
    p = tmp_path / "p.yaml"
    p.write_text(f"name: p\nworld: {flat_world_dir}\nmissions: [a.yaml, b.yaml, c.yaml]\n")
    runs = tmp_path / "runs"
    code = SECOND_SIGNAL.format(kit=str(Path(__file__).parent), pipeline=str(p), runs=str(runs))
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen([sys.executable, "-c", code], env=env, text=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, start_new_session=True)
    try:
        writing = lambda: len([d for d in runs.glob(".*.tmp-*") if d.is_dir()]) >= 2  # noqa: E731
        assert wait_for(lambda: writing() or proc.poll() is not None, timeout=180), "no case started writing"
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
        tree = descendants(proc.pid)
        proc.send_signal(signal.SIGTERM)  # stop: the workers get 30 s to write their cases...
        time.sleep(1.0)
        proc.send_signal(signal.SIGTERM)  # ...but a second signal aborts at once
        proc.wait(timeout=60)
        assert wait_for(lambda: not any(alive(c) for c in tree), timeout=DEADLINE_S), "workers left behind"
        leftovers = sorted(d.name for d in runs.iterdir() if ".tmp-" in d.name or ".old-" in d.name)
        assert leftovers == [], f"half-written folders: {leftovers}"
        cases = json.loads((runs / "batch.json").read_text())["cases"]
        assert {c["status"] for c in cases} == {"interrupted"}
        assert not [d for d in runs.iterdir() if d.is_dir() and not d.name.startswith(".")]  # none finished
    finally:
        kill_session(proc)
