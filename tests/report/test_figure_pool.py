"""The report's figure pool: on Linux it forks its workers from the report's process (after importing the drawing
code once) when that process runs no other thread, else it uses a fork server (forking a multi-threaded process can
copy a lock another thread holds); either way the workers draw exactly what the report's process draws, and leave
the stop signals to it."""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from pathlib import Path

import pytest

from vinecli.report.render import _pool_context


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


_FORKED = """
import signal, sys
from vinecli.report.render import FigurePool, draw_item
runs = sys.argv[1]
items = [(runs + "/gust", "fig16"), (runs + "/gust", "map"), (runs + "/takeoff", "map")]
with FigurePool(2) as pool:
    assert pool._started is None  # forked at once, from this single-threaded process
    drawn = [pool.submit(*item).result() for item in items]
    handlers = pool._ex.submit(signal.getsignal, signal.SIGINT).result(), \\
        pool._ex.submit(signal.getsignal, signal.SIGTERM).result()
assert handlers == (signal.SIG_IGN, signal.SIG_DFL), handlers  # the report's process ends the pool
for item, (run_dir, name, data, note) in zip(items, drawn, strict=True):
    assert (run_dir, name) == item and data and not note
    assert data == draw_item(*item)[2]  # byte for byte what this process draws
print("forked workers drew", len(drawn))
"""


@pytest.mark.skipif(sys.platform != "linux", reason="workers are forked from the report's process on Linux only")
def test_forked_workers_draw_what_this_process_draws(ci_runs: Path) -> None:
    # in a fresh process: the test runner's own threads (pytest-xdist) would make the pool use its fork server
    import os
    import subprocess

    res = subprocess.run([sys.executable, "-c", _FORKED, str(ci_runs)], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "MPLBACKEND": "Agg"})
    assert res.returncode == 0 and "forked workers drew 3" in res.stdout, res.stderr[-2000:]


def _children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == pid and fields[0] != "Z":
            out.append(int(stat.parent.name))
    return out


@pytest.mark.skipif(sys.platform != "linux", reason="workers are forked from the report's process on Linux only")
def test_kill_9_of_the_report_takes_its_figure_workers_with_it(ci_runs: Path, tmp_path: Path) -> None:
    import os
    import subprocess
    import time

    env = {**os.environ, "VINECLI_CACHE_DIR": "off", "MPLBACKEND": "Agg"}
    proc = subprocess.Popen([sys.executable, "-m", "vinecli", "report", str(ci_runs), "--out", str(tmp_path / "r"),
                             "--workers", "2"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 120.0
        while len(workers := _children(proc.pid)) < 2 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        assert len(workers) >= 2, "the report ended before its figure workers were seen"
        proc.kill()
        proc.wait()
        deadline = time.monotonic() + 10.0
        while any(Path(f"/proc/{w}").exists() for w in workers) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = [w for w in workers if Path(f"/proc/{w}").exists()
                and Path(f"/proc/{w}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"]
        assert not left, f"figure workers outlived the report: {left}"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        for w in workers:  # what outlived it: a failure leaves nothing running
            with contextlib.suppress(ProcessLookupError):
                os.kill(w, signal.SIGKILL)
