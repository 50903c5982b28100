"""SIGTERM / SIGINT for batches: the main process asks, the workers stop at the next step.

* Main process (:class:`vinecli.stop_signals.StopSignals`, the one handler ``run mission`` uses too): the
  first SIGTERM or SIGINT records the signal, which the batch loop polls: it stops submitting, raises the
  pool's shared stop flag (:func:`make_stop_flag`) and waits for the workers' partial runs. Inside an
  ``interruptible()`` section (e.g. while a world is being built) the signal also raises
  :class:`~vinecli.stop_signals.StopRequested`. A second signal aborts at once
  (:class:`~vinecli.stop_signals.Aborted`).
* Worker processes (:func:`worker_init`, the local pool's initializer) own their signals (the run's
  :class:`~vinecli.stop_signals.StopSignals` installs nothing there). SIGINT is ignored (a terminal's Ctrl-C
  reaches the whole process group; the batch process turns it into the shared flag). A SIGTERM to a worker
  running a case sets a local flag; :func:`worker_should_stop` reports either flag to the simulation loop
  (polled every step: a plain read of shared memory), which ends the run as ``interrupted`` and writes it;
  more SIGTERMs while it does change nothing (the pool's shutdown ends a worker that takes too long:
  :func:`vinecli.batch.executors.stop_local_pool`). A SIGTERM to an idle worker ends it at once, by the
  signal: ``ProcessPoolExecutor`` terminates the workers of a broken pool with one SIGTERM each and then
  joins them, which hung for ever while an idle worker, waiting for its next case, only noted the signal.
  The shared flag reaches workers still starting up, where a signal would kill them.
* A worker whose batch process dies without a word (``kill -9``) follows it
  (:func:`vinecli.lifeline.watch_process`): a case in flight is stopped and written ``interrupted``
  if that takes less than :data:`PARENT_GRACE_S`, then the worker kills itself; an idle worker goes
  at once. The fork server exits by itself once the batch and its workers are gone.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

from vinecli.stop_signals import leave_signals_to_owner

#: seconds a worker whose batch process died gives its running case to write itself ``interrupted``
PARENT_GRACE_S = 2.0


_WORKER_STOP = False
_SHARED_STOP: Any = None
_IN_CASE = False
_FORK_SERVER: int | None = None  # the process that forked this worker, when it is not the batch itself


def make_stop_flag(ctx: Any) -> Any:
    """A shared byte (0 = run, 1 = stop) for :func:`worker_init` of a pool made with context ``ctx``."""
    return ctx.RawValue("b", 0)


def _worker_sigterm(signum: int, frame: FrameType | None) -> None:
    """A worker's SIGTERM: running a case, its run stops at the next step; idle, the worker ends now, by the signal
    (it holds nothing to save; its pool sees a worker killed by SIGTERM, as ``terminate()`` expects)."""
    global _WORKER_STOP
    if _IN_CASE:
        _WORKER_STOP = True
        return
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)
    os._exit(128 + signum)  # not reached: the default action of SIGTERM ends the process


def _batch_gone() -> None:
    """The batch process died: the fork server that started this worker goes at once (it would wait for the
    last worker and then take seconds to exit); the case in flight is stopped and given
    :data:`PARENT_GRACE_S` to be written; then this worker goes."""
    global _WORKER_STOP
    _WORKER_STOP = True
    if _FORK_SERVER is not None and os.getppid() == _FORK_SERVER:  # still our parent: never another process
        os.kill(_FORK_SERVER, signal.SIGKILL)
    if _IN_CASE:
        time.sleep(PARENT_GRACE_S)
    os.kill(os.getpid(), signal.SIGKILL)


def worker_init(stop_flag: Any = None, batch_pid: int | None = None) -> None:
    """Process-pool initializer: SIGINT ignored (between runs), SIGTERM or ``stop_flag`` set ->
    :func:`worker_should_stop`; the worker follows the batch process ``batch_pid`` when it dies."""
    global _SHARED_STOP, _FORK_SERVER
    _SHARED_STOP = stop_flag
    leave_signals_to_owner()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _worker_sigterm)
    if batch_pid is not None:
        _FORK_SERVER = os.getppid() if os.getppid() != batch_pid else None
        from vinecli.lifeline import watch_process

        watch_process(batch_pid, _batch_gone)


@contextmanager
def case_running() -> Iterator[None]:
    """Mark the worker busy with a case (a dying batch then leaves it time to write the case)."""
    global _IN_CASE
    _IN_CASE = True
    try:
        yield
    finally:
        _IN_CASE = False


def worker_should_stop() -> bool:
    """True once this worker got SIGTERM or its pool's stop flag was raised (polled every simulation step)."""
    return _WORKER_STOP or (_SHARED_STOP is not None and _SHARED_STOP.value != 0)
