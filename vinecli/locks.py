"""One writer per output: a lock per run id, batch folder and output folder, so a second writer
exits 2 at once instead of interleaving its files with the first's.

:func:`output_lock` takes an exclusive ``flock`` on a hidden lock file next to what it guards
(``.<name>.lock`` beside the folder or file, ``.vinecli.lock`` inside a runs folder) and writes the
holder's pid into it. A second writer, in any process, gets OutputError (exit 2) ``in use by pid N``
at once instead of racing. The kernel drops an ``flock`` when its holder dies, however it dies
(``kill -9`` included), so a lock left by a dead process is free: the next writer takes it over with the
same atomic call. The file is removed on release; a writer that locked a file just unlinked by its
previous holder notices (the path no longer names the inode it locked) and locks again.

Locks are re-entrant within a process (a batch worker's run id, a run that writes through
:func:`vinecli.outputs.atomic_output_dir`): a nested acquisition of the same lock only counts.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from vinecli.errors import OutputError

__all__ = ["lock_path", "output_lock", "remove_if_free"]

_HELD: dict[Path, int] = {}  # lock file (absolute) -> nesting depth, in this process
_GUARD = threading.Lock()


def lock_path(target: Path, *, inside: bool = False) -> Path:
    """The lock file guarding ``target``: ``.<name>.lock`` beside it, or ``.vinecli.lock`` inside it."""
    target = Path(os.path.abspath(target))
    return target / ".vinecli.lock" if inside else target.with_name(f".{target.name}.lock")


def _holder(path: Path) -> str:
    try:
        pid = path.read_text(encoding="ascii").strip()
    except (OSError, UnicodeDecodeError):
        return "another process"
    return f"pid {pid}" if pid.isdigit() else "another process"


def _acquire(path: Path, what: Path) -> int:
    """Lock ``path`` (created if needed) for this process; returns the open descriptor."""
    for _ in range(100):
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0), 0o666)
        except OSError as exc:
            raise OutputError(f"cannot create the lock file {path.name} ({exc.strerror})", path=what) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise OutputError(f"in use by {_holder(path)} (another vinecli is writing it; lock {path.name})",
                              path=what) from None
        try:
            same = os.stat(path, follow_symlinks=False).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode("ascii"))
            return fd
        os.close(fd)  # the previous holder removed the file after we opened it: lock the new one
    raise OutputError("cannot take the lock (it keeps being replaced)", path=what)


@contextmanager
def output_lock(target: str | Path, *, inside: bool = False) -> Iterator[Path]:
    """Hold the exclusive lock of ``target`` (see the module docstring) for the ``with`` block; OutputError
    (exit 2) ``in use by pid N`` when another process holds it. The parent folder must exist."""
    target = Path(target)
    path = lock_path(target, inside=inside)
    with _GUARD:
        depth = _HELD.get(path, 0)
        if depth:
            _HELD[path] = depth + 1
    if depth:
        try:
            yield path
        finally:
            with _GUARD:
                _HELD[path] -= 1
        return
    fd = _acquire(path, target)
    with _GUARD:
        _HELD[path] = 1
    try:
        yield path
    finally:
        with _GUARD:
            del _HELD[path]
        with contextlib.suppress(OSError):
            path.unlink()
        os.close(fd)  # closing drops the flock


def remove_if_free(path: Path) -> bool:
    """Remove the vinecli lock file ``path`` (it holds a pid) if no process holds it (its holder died); True
    if removed."""
    try:
        fd = os.open(path, os.O_RDWR | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        return False
    try:
        ours = os.read(fd, 32).strip().isdigit()  # a pid: vinecli's lock file, not a user's ".x.lock"
        if ours and os.stat(path, follow_symlinks=False).st_ino == os.fstat(fd).st_ino:
            path.unlink()
            return True
        return False
    except OSError:
        return False
    finally:
        os.close(fd)
