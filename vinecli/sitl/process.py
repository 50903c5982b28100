"""Process supervision every firmware bridge shares: free ports, an instance number reserved under a
lock file, and a firmware child process that dies with the process that started it.

An instance number is reserved with an exclusive lock file (``$TMPDIR/vinecli-<firmware>/instance-N.lock``)
held for the life of the run, and only taken when the firmware's ports for it are free, so parallel
batch workers (``run batch --jobs 2``) never share an instance.
"""

from __future__ import annotations

import contextlib
import fcntl
import socket
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO

from vinecli.errors import AutopilotError
from vinecli.lifeline import die_with_parent  # the firmware's preexec_fn: SIGKILL when its parent dies

AUTO_INSTANCES = range(10, 100)  # 0..9 are left to people running a firmware by hand


def port_free(port: int, kind: int, host: str = "127.0.0.1") -> tuple[bool, str]:
    """Can vinecli bind ``port`` now (and if not, the OS's reason)? TCP with SO_REUSEADDR, as vinecli's
    server binds: a connection of the last run in TIME_WAIT does not count, a listener does. UDP without
    it (it would share a port)."""
    s = socket.socket(socket.AF_INET, kind)
    if kind == socket.SOCK_STREAM:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        s.bind((host, port))
    except OSError as exc:
        return False, exc.strerror or str(exc)
    finally:
        s.close()
    return True, ""


class InstanceLock:
    """An exclusive claim on one firmware instance number (released by :meth:`release`)."""

    def __init__(self, instance: int, fh: IO[str]) -> None:
        self.instance = instance
        self._fh: IO[str] | None = fh

    def release(self) -> None:
        """Drop the lock. Idempotent."""
        if self._fh is not None:
            with contextlib.suppress(OSError):
                fcntl.flock(self._fh, fcntl.LOCK_UN)
            self._fh.close()
            self._fh = None


def reserve_instance(firmware: str, ports_free: Callable[[int], bool],
                     candidates: range | list[int] = AUTO_INSTANCES) -> InstanceLock:
    """Lock the first instance of ``firmware`` whose lock file is free and for which ``ports_free(i)``."""
    lock_dir = Path(tempfile.gettempdir()) / f"vinecli-{firmware.lower()}"
    lock_dir.mkdir(exist_ok=True)
    for i in candidates:
        fh = (lock_dir / f"instance-{i}.lock").open("w")
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.close()
            continue
        if ports_free(i):
            return InstanceLock(i, fh)
        fcntl.flock(fh, fcntl.LOCK_UN)
        fh.close()
    raise AutopilotError(f"no free {firmware} instance in {candidates[0]}..{candidates[-1]} "
                         "(all locked or ports in use)")


__all__ = ["AUTO_INSTANCES", "InstanceLock", "die_with_parent", "port_free", "reserve_instance"]
