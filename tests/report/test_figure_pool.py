"""The report's figure pool: on Linux it forks its workers from the report's process (after importing the drawing
code once) when that process runs no other thread, else it uses a fork server (forking a multi-threaded process can
copy a lock another thread holds); either way the workers draw exactly what the report's process draws, and leave
the stop signals to it."""

from __future__ import annotations

import signal
import sys
import threading
from pathlib import Path

import pytest

from vinecli.report.render import FigurePool, _pool_context, draw_item


def test_a_process_running_another_thread_is_not_forked() -> None:
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        ctx, forks = _pool_context()
    finally:
        stop.set()
        other.join()
    assert not forks and ctx.get_start_method() in ("forkserver", "spawn")


@pytest.mark.skipif(sys.platform != "linux", reason="workers are forked from the report's process on Linux only")
def test_forked_workers_draw_what_this_process_draws(ci_runs: Path) -> None:
    if threading.active_count() > 1:
        pytest.skip("this test process runs other threads (a test runner's): the pool would use its fork server")
    items = [(str(ci_runs / "gust"), "fig16"), (str(ci_runs / "gust"), "map"), (str(ci_runs / "takeoff"), "map")]
    with FigurePool(2) as pool:
        assert pool._started is None  # forked at once, from this thread
        drawn = [pool.submit(*item).result() for item in items]
        handlers = pool._ex.submit(signal.getsignal, signal.SIGINT).result(), \
            pool._ex.submit(signal.getsignal, signal.SIGTERM).result()
    assert handlers == (signal.SIG_IGN, signal.SIG_DFL)  # the report's process ends the pool, not the CLI's handler
    for item, (run_dir, name, data, note) in zip(items, drawn, strict=True):
        assert (run_dir, name) == item and data and not note
        assert data == draw_item(*item)[2]  # byte for byte what this process draws
