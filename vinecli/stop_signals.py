"""SIGTERM and SIGINT for every command: the first asks the work to stop, the second aborts it at once.

One handler (:class:`StopSignals`) for ``run mission`` and ``run batch``: the first signal is recorded
(:attr:`StopSignals.signum`, polled by the simulation loop and the batch loop, which then stop and write
what they have); a second one raises :class:`Aborted`, a ``KeyboardInterrupt``, so every ``with`` block on
the way out runs (temporary folders removed, locks released) and the CLI exits 128 + N with one line.
Inside :meth:`StopSignals.interruptible` (work that does not poll) the first signal raises
:class:`StopRequested` instead.

Outside those sections the CLI turns SIGTERM into :class:`Aborted` too (:func:`abort_on_sigterm`), so a command
stopped by ``kill`` cleans up like one stopped by Ctrl-C. Signals are handled in the main thread only;
elsewhere these context managers do nothing, and in a process whose signals another handler owns
(:func:`leave_signals_to_owner`: a batch worker) neither.
"""

from __future__ import annotations

import logging
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

__all__ = ["STOP_SIGNALS", "Aborted", "StopRequested", "StopSignals", "abort_on_sigterm", "leave_signals_to_owner",
           "signal_name"]

STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT)

log = logging.getLogger(__name__)

_OWNED_ELSEWHERE = False  # this process's stop signals belong to another handler (:func:`leave_signals_to_owner`)


def leave_signals_to_owner() -> None:
    """From now on :class:`StopSignals` installs no handler in this process: another one owns its stop signals and
    stops the work by other means (a batch worker: :func:`vinecli.batch.signals.worker_init`, whose handler raises
    the flag the run polls, and ends an idle worker at once)."""
    global _OWNED_ELSEWHERE
    _OWNED_ELSEWHERE = True


def signal_name(signum: int) -> str:
    """``SIGTERM``, ``SIGINT``... (the number for an unknown signal)."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


class Aborted(KeyboardInterrupt):
    """Stop at once: a second stop signal, or SIGTERM outside a section that stops gracefully (a
    KeyboardInterrupt, so broad ``except Exception`` handlers never swallow it)."""

    def __init__(self, signum: int, second: bool = False) -> None:
        super().__init__(signum)
        self.signum = signum
        self.second = second


class StopRequested(BaseException):  # noqa: N818 - like KeyboardInterrupt, not an error
    """The first stop signal, raised inside :meth:`StopSignals.interruptible` (not an Exception: broad handlers
    must not eat it)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


class StopSignals:
    """Context manager installing the SIGTERM/SIGINT handler (main thread only): the first signal sets
    :attr:`signum` (and calls ``on_first``); the second raises :class:`Aborted`."""

    def __init__(self, on_first: Callable[[int], None] | None = None) -> None:
        self.signum: int | None = None
        self.on_first = on_first
        self._raise = False
        self._old: dict[int, Any] = {}

    @property
    def name(self) -> str:
        return signal_name(self.signum) if self.signum is not None else ""

    def handle(self, signum: int, frame: FrameType | None = None) -> None:
        """The signal handler (also callable by hand, as a test or a watchdog would)."""
        if self.signum is not None:
            raise Aborted(signum, second=True)
        self.signum = signum
        if self.on_first is not None:
            self.on_first(signum)
        if self._raise:
            raise StopRequested(signum)

    @contextmanager
    def interruptible(self) -> Iterator[None]:
        """Inside: the first signal also raises :class:`StopRequested` (for work that does not poll)."""
        if self.signum is not None:
            raise StopRequested(self.signum)
        self._raise = True
        try:
            yield
        finally:
            self._raise = False

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread() and not _OWNED_ELSEWHERE:
            for s in STOP_SIGNALS:
                self._old[s] = signal.signal(s, self.handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for s, old in self._old.items():
            signal.signal(s, old)
        self._old.clear()


def _abort(signum: int, frame: FrameType | None) -> None:
    raise Aborted(signum)


def abort_on_sigterm() -> None:
    """From now on SIGTERM raises :class:`Aborted` in the main thread (as SIGINT raises KeyboardInterrupt), so
    a killed command still removes its temporary files and releases its locks."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _abort)
