"""A second SIGTERM leaves nothing half-written. One handler (``vinecli.stop_signals``) for
``run mission`` and ``run batch``: the first signal stops the work at the next step, the second aborts at once,
also while the run is being written, and the exit is 143 with one line; no temporary folder, no lock is left.
Real processes, real signals."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from attack_kit import IDLE, kill_session, mission, vinecli_proc, wait_for
from repo_paths import REPO

from vinecli.stop_signals import Aborted, StopRequested, StopSignals


def test_the_first_signal_asks_the_second_aborts() -> None:
    said: list[int] = []
    s = StopSignals(on_first=said.append)
    s.handle(signal.SIGTERM)
    assert s.signum == signal.SIGTERM and said == [signal.SIGTERM] and s.name == "SIGTERM"
    with pytest.raises(Aborted) as info:
        s.handle(signal.SIGINT)
    assert info.value.signum == signal.SIGINT and info.value.second
    assert isinstance(info.value, KeyboardInterrupt)  # no `except Exception` swallows it
    t = StopSignals()
    with pytest.raises(StopRequested), t.interruptible():
        t.handle(signal.SIGTERM)


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if ".tmp-" in p.name or ".old-" in p.name
                  or p.name.endswith(".lock")) if folder.is_dir() else []


#: the second SIGTERM while run_mission writes the run (its summary.json: the run folder half-written), the first
#: one while it flies: deterministic, whatever the machine's speed
SECOND_WHILE_WRITING = """
import os, signal, sys
from vinecli.runs import rundir
from vinecli.runs.mission import run_mission
from vinecli.runs.request import RunRequest

write = rundir.write_summary

def write_summary(*args, **kwargs):
    os.kill(os.getpid(), signal.SIGTERM)  # the second signal, inside the atomic write
    return write(*args, **kwargs)

rundir.write_summary = write_summary
sent = []

def progress(sim_t, wall_t):
    if not sent and sim_t > 0.5:
        sent.append(1)
        os.kill(os.getpid(), signal.SIGTERM)  # the first: stop at the next step

try:
    run_mission(RunRequest(mission=sys.argv[1], world_dir=sys.argv[2], runs_dir=sys.argv[3]), progress=progress)
except KeyboardInterrupt as exc:
    print("aborted", getattr(exc, "signum", None), getattr(exc, "second", None))
    sys.exit(143)
print("not aborted")
"""


def test_a_second_sigterm_while_the_run_is_written_leaves_nothing(flat_world_dir: Path, tmp_path: Path) -> None:
    m = mission(tmp_path, "idle", text=IDLE)
    runs = tmp_path / "runs"
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    r = subprocess.run([sys.executable, "-c", SECOND_WHILE_WRITING, str(m), str(flat_world_dir), str(runs)],
                       env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 143 and "aborted 15 True" in r.stdout, (r.returncode, r.stdout, r.stderr[-2000:])
    assert _leftovers(runs) == []
    assert not (runs / "idle-s0").exists()  # aborted before its swap: no run, nothing half-written


@pytest.mark.parametrize("gap_s", [0.05, 0.5, 2.0])
def test_sigterm_twice_from_the_cli_exits_143_with_one_line_and_no_leftover(flat_world_dir: Path, tmp_path: Path,
                                                                           gap_s: float) -> None:
    """As the attack did it: ``kill`` twice, ``gap_s`` apart, whatever the run is doing then."""
    from vinecli.outputs import manifest_problem

    m = mission(tmp_path, "idle", text=IDLE)
    runs = tmp_path / "runs"
    proc = vinecli_proc("run", "mission", m, "--world", flat_world_dir, "--out", runs)
    try:
        assert wait_for(lambda: (runs / ".idle-s0.lock").exists() or proc.poll() is not None, 180)
        time.sleep(1.0)  # flying
        proc.send_signal(signal.SIGTERM)
        time.sleep(gap_s)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        kill_session(proc)
    # 143, or killed by the signal itself once the command had written and said everything and Python was shutting
    # down (its handlers are gone then): a shell shows 143 for both
    assert proc.returncode in (143, -signal.SIGTERM), err
    lines = [ln for ln in err.splitlines() if ln.strip() and "stopping the run at the next step" not in ln]
    assert len(lines) == 1 and lines[0].startswith("vinecli: error:") and "SIGTERM" in lines[0], err
    assert _leftovers(runs) == []
    run = runs / "idle-s0"
    assert not run.exists() or manifest_problem(run) is None  # the partial run whole, or none at all
