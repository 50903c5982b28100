"""Executors for batches: one ``concurrent.futures.Executor`` seam, two implementations.

* ``local``: ``ProcessPoolExecutor`` with the ``forkserver`` start method and
  ``max_tasks_per_child`` to cap memory growth of long batches. The fork server is a fresh,
  single-threaded interpreter that imports :data:`WORKER_PRELOAD` once; every worker is forked
  from it with those modules loaded (no PyBullet client, no BLAS thread and no parent state is
  ever forked), so a worker starts in milliseconds instead of ~0.7 s of imports each. Such a pool is
  shut down by :func:`stop_local_pool`, which never waits for ever: a grace period, SIGTERM, another, SIGKILL.
* ``dask``: ``dask.distributed.Client(...).get_executor()`` on a scheduler address, or on a
  local cluster (``LocalCluster``) when none is given. Same submit/wait code path.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing as mp
import os
import signal
import time
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from contextlib import contextmanager
from typing import Any

from vinecli.batch.signals import make_stop_flag, worker_init
from vinecli.errors import InputError, RuntimeFailure

log = logging.getLogger(__name__)

EXECUTORS = ("local", "dask")
#: cases a local worker runs before it is replaced: a worker's memory levels off after its first cases
#: (measured 197 MB after one case, 293-319 MB over the next eleven, CI missions incl. the job), so
#: recycling is a guard, not a need
WORKER_CASES = 32
#: modules the fork server imports before forking workers: the case runner and what a case imports
#: on first use (row coverage's KD-tree, the sprayer's filters, the Parquet writer)
WORKER_PRELOAD = ["vinecli.batch.case", "vinecli.runs.mission", "vinecli.world.engine", "vinecli.missions.job",
                  "vinecli.phase_items.spray_legs", "scipy.spatial", "scipy.ndimage", "pyarrow.parquet"]


def _context() -> Any:
    """The local pools' multiprocessing context: ``forkserver`` preloading :data:`WORKER_PRELOAD` (the
    preload list is read when the fork server starts: once per process)."""
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(WORKER_PRELOAD)
    return ctx


def start_fork_server() -> None:
    """Start the local pools' fork server now: it imports :data:`WORKER_PRELOAD` while the caller goes on
    (e.g. prepares the worlds), instead of when the first worker is needed."""
    from multiprocessing import forkserver

    _context()
    forkserver.ensure_running()


def make_local_executor(workers: int, max_tasks_per_child: int = WORKER_CASES, stop_flag: Any = None) -> ProcessPoolExecutor:
    """Process pool, workers forked from the preloaded fork server and recycled every ``max_tasks_per_child``
    cases, stops handled as :func:`vinecli.batch.signals.worker_init` sets up (``stop_flag``: from
    :func:`local_stop_flag`; the workers follow this process when it dies, ``kill -9`` included)."""
    return ProcessPoolExecutor(max_workers=workers, mp_context=_context(),
                               max_tasks_per_child=max_tasks_per_child, initializer=worker_init,
                               initargs=(stop_flag, os.getpid()))


#: seconds a local pool's workers get to end by themselves when the pool shuts down, and again after SIGTERM
POOL_GRACE_S = 10.0


def stop_local_pool(ex: Executor, grace_s: float = POOL_GRACE_S) -> dict[int, str]:
    """Shut the pool ``ex`` down without ever waiting for ever: its pending cases cancelled, its workers given
    ``grace_s`` to end (an idle one ends at once on the pool's end marker), then SIGTERM (an idle worker ends at
    once, a running case stops at its next step and is written) and ``grace_s`` more, then SIGKILL; the pool's
    manager thread joined last. Returns how each worker (by pid) was ended: ``"itself"``, ``"SIGTERM"`` or
    ``"SIGKILL"``."""
    procs = list((getattr(ex, "_processes", None) or {}).values())  # ProcessPoolExecutor has no public list
    manager = getattr(ex, "_executor_manager_thread", None)
    ex.shutdown(wait=False, cancel_futures=True)
    how: dict[int, str] = {}
    for step, send in (("itself", None), ("SIGTERM", signal.SIGTERM), ("SIGKILL", signal.SIGKILL)):
        live = [p for p in procs if p.is_alive()]
        for p in live:
            how[p.pid] = step
            if send is not None:
                log.debug("pool worker %s still running after %g s: %s", p.pid, grace_s, step)
                with contextlib.suppress(ProcessLookupError):
                    os.kill(p.pid, send)
        deadline = time.monotonic() + (grace_s if send != signal.SIGKILL else 5.0)
        for p in live:
            p.join(max(0.0, deadline - time.monotonic()))
    if manager is not None:
        manager.join(5.0)  # its workers are gone: it ends at once
    return how


def local_stop_flag() -> Any:
    """The shared stop flag for :func:`make_local_executor` pools (set ``.value = 1`` to stop their runs)."""
    return make_stop_flag(_context())


@contextmanager
def dask_executor(workers: int, scheduler: str | None = None, *, processes: bool = True) -> Iterator[Executor]:
    """A Dask-backed Executor: connect to ``scheduler`` or start a LocalCluster of ``workers`` processes."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:  # pragma: no cover - the dask extra is not installed
        raise InputError("the dask executor needs 'pip install vinecli[dask]'") from exc
    cluster: Any = None
    try:
        if scheduler:
            client = Client(scheduler, timeout="20s")
        else:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=processes,
                                   dashboard_address=None, silence_logs=logging.WARNING)
            client = Client(cluster)
    except OSError as exc:
        raise RuntimeFailure(f"cannot reach the Dask scheduler: {exc}", path=scheduler) from exc
    try:
        yield client.get_executor(pure=False)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
