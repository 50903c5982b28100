"""Child processes die with the process that started them, however it dies (``kill -9``
included): no firmware or worker outlives a batch.

Three mechanisms, for the kinds of children:

* :func:`die_with_parent` for programs vinecli executes (firmware: PX4, ArduPilot), as the
  ``preexec_fn`` of :class:`subprocess.Popen`: the kernel sends the child SIGKILL when its parent
  dies (Linux ``PR_SET_PDEATHSIG``), ``kill -9`` included; a parent that died before the call is
  noticed at once.
* :class:`GroupLifeline` for what those programs start in turn: a firmware started through a wrapper script
  (``#!/bin/sh`` that runs ``arducopter`` without ``exec``) has children the death signal does not reach. The
  firmware runs in its own process group; a tiny watcher (``sh``, in a session of its own) waits on a pipe
  only vinecli holds and kills the whole group when the pipe closes without a word, which is what ``kill -9``
  of vinecli does. A normal stop ends the group itself (:func:`group_alive`) and dismisses the watcher.
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
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path

__all__ = ["OWNER", "GroupLifeline", "die_with_parent", "group_alive", "owner_alive", "owner_tag", "pid_alive", "start_ticks", "watch_process"]

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


def start_ticks(pid: int) -> int | None:
    """When process ``pid`` started (clock ticks since boot, /proc/PID/stat field 22), None when it is gone or
    the system does not say. With the pid it names one process for good: a pid is reused, the pair is not."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return int(f.read().rsplit(b")", 1)[1].split()[19])
    except (OSError, IndexError, ValueError):
        return None


def owner_tag(pid: int | None = None) -> str:
    """``PID.START`` of this process (or ``pid``): what vinecli puts in the names of its temporary files and folders,
    so a later vinecli can tell those of a live process (kept) from those a killed one left (removed)."""
    pid = os.getpid() if pid is None else pid
    return f"{pid}.{start_ticks(pid) or 0}"


#: the owner part of a temporary name: ``PID`` (older vinecli) or ``PID.START``
OWNER = r"(?P<pid>\d+)(?:\.(?P<start>\d+))?"


def owner_alive(pid: int, start: int | None) -> bool:
    """Is the process that made a temporary file still running: ``pid`` alive and, when ``start`` is known (not
    None or 0), started at ``start`` (a reused pid is another process)."""
    if pid == os.getpid():
        return start in (None, 0) or start == start_ticks(pid)
    if not pid_alive(pid):
        return False
    if not start:
        return True  # an older name without the start time: keep it while any process has the pid
    now = start_ticks(pid)
    return now is None or now == start


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


def group_alive(pgid: int) -> bool:
    """Does process group ``pgid`` still hold a live process (zombies waiting for their reaper do not count)?"""
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_bytes().rsplit(b")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if len(fields) > 2 and int(fields[2]) == pgid and fields[0] != b"Z":
            return True
    return not Path("/proc/self/stat").exists()  # no /proc: trust killpg


#: the watcher: a word on stdin dismisses it; the end of stdin without one (vinecli died) kills the group
_WATCHER = 'read -r word || kill -9 "-$1" 2>/dev/null'


class GroupLifeline:
    """Kill process group ``pgid`` (SIGKILL) if this process dies before :meth:`dismiss` (module docstring)."""

    def __init__(self, pgid: int) -> None:
        self.pgid = pgid
        r, self._w = os.pipe()  # both ends close-on-exec: only this process holds the writing end
        try:
            self._watcher: subprocess.Popen[bytes] | None = subprocess.Popen(
                ["/bin/sh", "-c", _WATCHER, "vinecli-lifeline", str(pgid)], stdin=r, stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL, start_new_session=True)  # a Ctrl-C to vinecli's group does not end it
        except OSError:
            self._watcher = None  # no /bin/sh: the firmware's own death signal is all there is
        finally:
            os.close(r)

    def dismiss(self) -> None:
        """The group was ended by its owner: let the watcher go without killing anything. Idempotent."""
        if self._w < 0:
            return
        with contextlib.suppress(OSError):
            os.write(self._w, b"done\n")
        os.close(self._w)
        self._w = -1
        if self._watcher is not None:
            with contextlib.suppress(subprocess.TimeoutExpired):
                self._watcher.wait(timeout=5.0)
