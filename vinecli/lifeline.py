"""Child processes die with the process that started them, however it dies (``kill -9``
included): no firmware or worker outlives a batch.

Two mechanisms, for the two kinds of children:

* :func:`die_with_parent` for programs vinecli executes (firmware: PX4, ArduPilot), as the
  ``preexec_fn`` of :class:`subprocess.Popen`: the kernel sends the child SIGKILL when its parent
  dies (Linux ``PR_SET_PDEATHSIG``), ``kill -9`` included; a parent that died before the call is
  noticed at once.
* :func:`watch_process` for Python workers whose parent is not the process they serve (a batch's
  workers are forked by the multiprocessing fork server, not by the batch): a daemon thread waits on
  the served process (a ``pidfd`` where the kernel has one, else a 0.2 s poll) and calls back when it
  ends. The fork server itself then exits on its own: it stops when the last process holding its
  ``alive`` pipe (the batch and its workers) is gone.
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import threading
import time
from collections.abc import Callable

__all__ = ["die_with_parent", "pid_alive", "watch_process"]

_PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int | None = None, sig: int = signal.SIGKILL) -> None:
    """Ask the kernel to send ``sig`` to this process when its parent dies; exit now if the parent (pid
    ``parent_pid``, taken before the fork) is already gone. Safe in a ``preexec_fn`` (no allocation-heavy
    work). A no-op where ``prctl`` does not exist (not Linux)."""
    import ctypes

    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, int(sig))
    if parent_pid is not None and os.getppid() != parent_pid:
        os._exit(1)


def pid_alive(pid: int) -> bool:
    """Is process ``pid`` alive (a zombie counts as gone)?"""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return f.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except (OSError, IndexError):
        return True


def _wait_for_exit(pid: int) -> None:
    try:
        fd = os.pidfd_open(pid)  # type: ignore[attr-defined]
    except (AttributeError, OSError):
        while pid_alive(pid):
            time.sleep(0.2)
        return
    try:
        while pid_alive(pid):
            select.select([fd], [], [], 1.0)
    finally:
        os.close(fd)


def watch_process(pid: int, on_exit: Callable[[], None]) -> threading.Thread:
    """Call ``on_exit()`` from a daemon thread as soon as process ``pid`` ends (at once if it is gone)."""
    def run() -> None:
        _wait_for_exit(pid)
        on_exit()

    t = threading.Thread(target=run, name=f"vinecli-watch-{pid}", daemon=True)
    t.start()
    return t
