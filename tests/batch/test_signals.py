"""SIGTERM / SIGINT to ``vinecli run batch`` (a real subprocess, real signals, the real loop):
the workers stop (no orphans), the running cases are written as ``interrupted`` partial runs, batch.json keeps
no case ``pending``, exit 143 / 130. ``--resume`` re-runs a case whose run directory fails its manifest."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from contextlib import suppress
from pathlib import Path

import pytest
from proc_tree import alive, descendants, simulating

import vinecli

SRC = str(Path(vinecli.__file__).resolve().parents[1])

MISSION = """\
name: {name}
vehicle: x500-sprayer
tank_fill_l: 0.5
max_duration_s: {maxdur}
record_rate_hz: 20
phases:
  - {{type: open_loop, duration_s: {hold}, rotor_speeds_rad_s: 0}}
"""


HOURS = 36000.0  # a case idles on the ground this long (s): at any loop speed, the signal comes first


def pipeline(d: Path, world: Path, *, hold: float, n: int = 3) -> Path:
    (d / "m.yaml").write_text(MISSION.format(name="hover", hold=hold, maxdur=hold + 60))
    entries = ", ".join(f"{{mission: m.yaml, name: c{i}}}" for i in range(n))
    p = d / "p.yaml"
    p.write_text(f"name: sig\nworld: {world}\nmissions: [{entries}]\n")
    return p


def vinecli_cmd(*args: str) -> list[str]:
    return [sys.executable, "-m", "vinecli", *args]


def env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", ""), "COLUMNS": "200"}


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_signal_stops_workers_and_writes_interrupted_runs(flat_world_dir: Path, tmp_path: Path, signum: int,
                                                          code: int) -> None:
    p = pipeline(tmp_path, flat_world_dir, hold=HOURS)
    runs = tmp_path / "runs"
    proc = subprocess.Popen(vinecli_cmd("run", "batch", str(p), "--out", str(runs), "--workers", "2"), env=env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        _signal_and_check(proc, runs, signum, code)
    finally:  # whatever happened, nothing of this batch's session survives the test
        with suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)


def _signal_and_check(proc: subprocess.Popen[str], runs: Path, signum: int, code: int) -> None:
    deadline = time.monotonic() + 120
    workers: set[int] = set()
    while time.monotonic() < deadline:
        workers = {w for w in descendants(proc.pid) if simulating(w)}
        if len(workers) >= 2 or proc.poll() is not None:
            break
        time.sleep(0.2)
    assert len(workers) >= 2, "the batch did not start two workers"
    time.sleep(3.0)  # into the simulation
    tree = descendants(proc.pid)
    proc.send_signal(signum)  # the main process only, as `timeout` and CI cancels do
    try:
        proc.wait(timeout=90)
    except subprocess.TimeoutExpired:
        pytest.fail(f"no exit 90 s after {signal.Signals(signum).name}")
    err = proc.stderr.read() if proc.stderr else ""
    assert proc.returncode == code, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) >= 1 and signal.Signals(signum).name in lines[-1], err
    deadline = time.monotonic() + 10
    while any(alive(c) for c in tree) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [c for c in tree if alive(c)], "orphaned worker processes"
    batch = json.loads((runs / "batch.json").read_text())
    statuses = {c["case"]: c["status"] for c in batch["cases"]}
    assert set(statuses.values()) == {"interrupted"}, statuses
    written = [c for c in batch["cases"] if c["error"] is None]
    not_run = [c for c in batch["cases"] if c["error"]]
    assert len(written) == 2 and len(not_run) == 1 and "not run" in not_run[0]["error"]
    for c in written:
        s = json.loads((runs / c["run_id"] / "summary.json").read_text())
        assert s["status"] == "interrupted" and 0 <= s["sim_time_s"] < HOURS  # 0: stopped while settling
    assert not (runs / not_run[0]["run_id"]).exists()


def test_resume_reruns_a_run_whose_files_fail_the_manifest(flat_world_dir: Path, tmp_path: Path) -> None:
    p = pipeline(tmp_path, flat_world_dir, hold=0.5, n=2)
    runs = tmp_path / "runs"
    first = subprocess.run(vinecli_cmd("run", "batch", str(p), "--out", str(runs)), env=env(), capture_output=True,
                           text=True, timeout=300)
    assert first.returncode == 0, first.stderr
    ts = runs / "c1" / "timeseries.parquet"
    ts.write_bytes(ts.read_bytes()[: ts.stat().st_size // 2])  # truncated: summary.json still says "completed"
    again = subprocess.run(vinecli_cmd("run", "batch", str(p), "--out", str(runs), "--resume"), env=env(),
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    cases = {c["case"]: c for c in json.loads((runs / "batch.json").read_text())["cases"]}
    assert cases["c0"]["skipped"] is True and cases["c1"]["skipped"] is False
    from vinecli.outputs import manifest_problem
    from vinecli.runs.rundir import read_timeseries

    assert manifest_problem(runs / "c1") is None and len(read_timeseries(ts)["t_s"]) > 10
