"""A local pool's workers and real signals (a real forkserver pool, the batch's own worker set-up, real SIGTERMs).

The full test suite once hung at exit: a pool broke, ``ProcessPoolExecutor`` sent each remaining worker one SIGTERM
and joined it, and an idle worker, waiting for its next case, only noted the signal (the run's "first signal stops"
rule) and waited on. Now an idle worker ends at once by SIGTERM; a busy one stops its run at the next step, writes
it ``interrupted`` and takes more SIGTERMs without dying half-way; and ``stop_local_pool`` never waits for ever
(grace, SIGTERM, grace, SIGKILL). A failing test here fails, it does not hang: every wait has a deadline and the
``pool`` fixture kills what is left.
"""

from __future__ import annotations

import json
import os
import signal
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import suppress
from pathlib import Path

import pytest
from proc_tree import alive

from vinecli.batch.case import CaseResult, run_one
from vinecli.batch.executors import local_stop_flag, make_local_executor, stop_local_pool
from vinecli.runs.request import RunRequest

HOLD = """\
name: hold
vehicle: x500-sprayer
max_duration_s: 36060
record_rate_hz: 2
phases:
  - {type: open_loop, duration_s: 36000, rotor_speeds_rad_s: 0}
"""


def worker_pid() -> int:
    """A task: the worker's pid (and a moment's work, so that a second task goes to a second worker)."""
    time.sleep(0.3)
    return os.getpid()


def stuck_ignoring_sigterm() -> None:
    """A task no signal but SIGKILL ends (a case stuck in C code that ignores SIGTERM)."""
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    time.sleep(3600)


def wait_until(done: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not done():
        if time.monotonic() > deadline:
            pytest.fail(f"{what}: not within {timeout:g} s")
        time.sleep(0.05)


def workers(ex: ProcessPoolExecutor) -> dict[int, object]:
    return {p.pid: p for p in (getattr(ex, "_processes", None) or {}).values()}


@pytest.fixture
def pool() -> Iterator[Callable[[int], ProcessPoolExecutor]]:
    """Local pools as ``run batch`` makes them; whatever a test leaves is killed, so a failure cannot hang pytest."""
    made: list[ProcessPoolExecutor] = []

    def make(n: int) -> ProcessPoolExecutor:
        made.append(make_local_executor(n, stop_flag=local_stop_flag()))
        return made[-1]

    yield make
    for ex in made:
        for pid in workers(ex):
            with suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        ex.shutdown(wait=False, cancel_futures=True)


def two_idle_workers(ex: ProcessPoolExecutor) -> tuple[int, int]:
    a, b = ex.submit(worker_pid), ex.submit(worker_pid)
    pids = (a.result(timeout=120), b.result(timeout=120))
    assert pids[0] != pids[1] and set(pids) == set(workers(ex)), "two tasks, two workers"
    return pids


@pytest.mark.parametrize("first", [signal.SIGTERM, signal.SIGKILL])
def test_an_idle_worker_ends_at_once_on_sigterm_and_a_broken_pool_ends(pool: Callable[[int], ProcessPoolExecutor],
                                                                         first: signal.Signals) -> None:
    ex = pool(2)
    a, b = two_idle_workers(ex)
    manager = ex._executor_manager_thread  # joins the workers of a broken pool: this is what hung
    procs = workers(ex)
    os.kill(a, first)  # SIGKILL: the pool breaks as when a case crashes its worker
    wait_until(lambda: not alive(a), 10, f"an idle worker ends on {first.name}")
    # the pool is broken now: its manager sent b one SIGTERM and joins it
    wait_until(lambda: not alive(b), 10, "the pool's terminate() ends the other idle worker")
    assert manager is not None
    manager.join(10)
    assert not manager.is_alive(), "the broken pool's manager thread still joins a worker"
    assert (procs[a].exitcode, procs[b].exitcode) == (-first, -signal.SIGTERM)  # by the signal, as terminate() expects
    with pytest.raises(BrokenProcessPool):
        ex.submit(worker_pid)


def test_stop_local_pool_ends_idle_workers_at_once(pool: Callable[[int], ProcessPoolExecutor]) -> None:
    ex = pool(2)
    a, b = two_idle_workers(ex)
    t0 = time.monotonic()
    how = stop_local_pool(ex, grace_s=30.0)
    assert how == {a: "itself", b: "itself"}  # they took the pool's end marker: neither signal was needed
    assert not alive(a) and not alive(b)
    assert time.monotonic() - t0 < 10.0  # no grace waited out (measured ~0.1 s)


def test_stop_local_pool_escalates_to_sigkill(pool: Callable[[int], ProcessPoolExecutor]) -> None:
    ex = pool(1)
    pid = ex.submit(worker_pid).result(timeout=120)
    ex.submit(stuck_ignoring_sigterm)
    time.sleep(1.0)  # the task has started and set SIGTERM aside
    t0 = time.monotonic()
    how = stop_local_pool(ex, grace_s=1.0)
    took = time.monotonic() - t0
    assert how == {pid: "SIGKILL"}
    assert not alive(pid)
    assert 2.0 <= took < 10.0  # a grace, SIGTERM ignored, a grace, SIGKILL


def _hold_request(tmp_path: Path, world: Path) -> RunRequest:
    (tmp_path / "hold.yaml").write_text(HOLD)
    return RunRequest(mission=tmp_path / "hold.yaml", world_dir=world, runs_dir=tmp_path / "runs", run_id="c0",
                      case="c0")


def _until_flying(ex: ProcessPoolExecutor, fut: Future[CaseResult], runs: Path) -> int:
    """The worker running ``fut``, once its run has begun (it holds the run id's lock) and had a moment to fly."""
    wait_until(lambda: fut.done() or (runs / ".c0.lock").exists(), 180, "the case starts")
    assert not fut.done(), fut.result()
    (pid,) = workers(ex)
    time.sleep(3.0)  # into the loop (a signal before it stops the run at its first step: also a stop)
    return pid


def test_a_busy_worker_writes_its_run_on_sigterm_twice_and_then_ends_on_the_next(
        pool: Callable[[int], ProcessPoolExecutor], flat_world_dir: Path, tmp_path: Path) -> None:
    ex = pool(1)
    runs = tmp_path / "runs"
    fut = ex.submit(run_one, _hold_request(tmp_path, flat_world_dir))
    pid = _until_flying(ex, fut, runs)
    os.kill(pid, signal.SIGTERM)
    time.sleep(0.2)
    os.kill(pid, signal.SIGTERM)  # a second one (a pool's terminate() after a group's SIGTERM): not half-written
    r = fut.result(timeout=120)
    assert r.status == "interrupted" and r.error is None, r
    summary = json.loads((runs / "c0" / "summary.json").read_text())
    assert summary["status"] == "interrupted" and 0 <= summary["sim_time_s"] < 36000
    assert not list(runs.glob(".c0.*"))  # no temporary, no lock
    # the stop takes ~0.3 s from the first SIGTERM to the written case: a second one that lands while the case runs
    # is ignored (the worker idles on, alive), one that lands after it finds the worker idle and ends it (the idle
    # rule); under load either happens, and both leave the case whole, which is what is asserted above
    if alive(pid):
        os.kill(pid, signal.SIGTERM)
    wait_until(lambda: not alive(pid), 10, "the now idle worker ends on SIGTERM")


def test_a_busy_worker_is_ended_by_the_pools_stop_after_its_grace(
        pool: Callable[[int], ProcessPoolExecutor], flat_world_dir: Path, tmp_path: Path) -> None:
    ex = pool(1)
    runs = tmp_path / "runs"
    fut = ex.submit(run_one, _hold_request(tmp_path, flat_world_dir))
    pid = _until_flying(ex, fut, runs)
    t0 = time.monotonic()
    how = stop_local_pool(ex, grace_s=5.0)  # the case flies on through the grace, stops on SIGTERM, is written
    assert time.monotonic() - t0 >= 5.0
    assert how == {pid: "SIGTERM"} and not alive(pid)
    assert fut.result(timeout=1).status == "interrupted"
    summary = json.loads((runs / "c0" / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert not list(runs.glob(".c0.*"))
