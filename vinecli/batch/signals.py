"""SIGTERM / SIGINT for batches: the main process asks, the workers stop at the next step.

* Main process (:class:`StopRequest`): the first SIGTERM or SIGINT records the signal, which the
  batch loop polls (:attr:`StopRequest.signum`): it stops submitting, raises the pool's shared stop
  flag (:func:`make_stop_flag`) and waits for the workers' partial runs. Inside a :meth:`StopRequest.interruptible` section
  (e.g. while a world is being built) the signal also raises :class:`BatchInterrupted`. A second
  signal aborts at once (KeyboardInterrupt).
* Worker processes (:func:`worker_init`, the local pool's initializer): SIGINT is ignored outside a
  run (a terminal's Ctrl-C reaches the whole process group; the run itself turns it into a stop)
  and a SIGTERM of their own sets a local flag. :func:`worker_should_stop` reports either flag to the
  simulation loop (polled every step: a plain read of shared memory), which ends the run as
  ``interrupted`` and writes it. The shared flag reaches workers still starting up, where a signal
  would kill them.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT)


class BatchInterrupted(BaseException):  # noqa: N818 - like KeyboardInterrupt, not an error
    """A stop signal arrived outside the batch loop (not an Exception: broad handlers must not eat it)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


class StopRequest:
    """Context manager installing the main process's SIGTERM/SIGINT handlers (main thread only)."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self._raise = False
        self._old: dict[int, Any] = {}

    @property
    def name(self) -> str:
        return signal.Signals(self.signum).name if self.signum is not None else ""

    def _handler(self, signum: int, frame: FrameType | None) -> None:
        if self.signum is not None:
            raise KeyboardInterrupt  # second signal: abort now
        self.signum = signum
        if self._raise:
            raise BatchInterrupted(signum)

    @contextmanager
    def interruptible(self) -> Iterator[None]:
        """Inside: a signal also raises :class:`BatchInterrupted` (for work that does not poll)."""
        if self.signum is not None:
            raise BatchInterrupted(self.signum)
        self._raise = True
        try:
            yield
        finally:
            self._raise = False

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():
            for s in STOP_SIGNALS:
                self._old[s] = signal.signal(s, self._handler)
        return self

    def __exit__(self, *exc: object) -> None:
        for s, old in self._old.items():
            signal.signal(s, old)
        self._old.clear()


_WORKER_STOP = False
_SHARED_STOP: Any = None


def make_stop_flag(ctx: Any) -> Any:
    """A shared byte (0 = run, 1 = stop) for :func:`worker_init` of a pool made with context ``ctx``."""
    return ctx.RawValue("b", 0)


def _worker_sigterm(signum: int, frame: FrameType | None) -> None:
    global _WORKER_STOP
    _WORKER_STOP = True


def worker_init(stop_flag: Any = None) -> None:
    """Process-pool initializer: SIGINT ignored (between runs), SIGTERM or ``stop_flag`` set ->
    :func:`worker_should_stop`."""
    global _SHARED_STOP
    _SHARED_STOP = stop_flag
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _worker_sigterm)


def worker_should_stop() -> bool:
    """True once this worker got SIGTERM or its pool's stop flag was raised (polled every simulation step)."""
    return _WORKER_STOP or (_SHARED_STOP is not None and _SHARED_STOP.value != 0)
