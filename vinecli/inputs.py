"""What a command reads: one set of inputs, known before anything is written, so no
output can replace one of them.

Every reader notes the files and folders it reads with :func:`note_input` (a spec and each ``base:`` it
inherits from, vehicles, world folders and the terrain and vehicle files a world spec names, DSMs,
point clouds, ``.plan`` files, pipelines, runs folders...). A command's library function reads
everything inside :func:`reading_inputs` first; the output guards of :mod:`vinecli.outputs`
(:func:`~vinecli.outputs.check_output_target` for folders, :func:`~vinecli.outputs.check_output_file`
for files, and the atomic writers, which call them again) then refuse, with exit 2 and one line naming
both paths, an output that is, contains or lies inside one of them. A ``reading_inputs`` opened inside
another passes its inputs up, so a command that calls another library function protects the inputs of
both, while each function still knows its own (for its manifest).

A new kind of input needs one call in its reader: ``note_input(path, "GeoJSON")``.

Files are also opened the one safe way here (:func:`open_input`, :func:`read_input_text`,
:func:`require_regular_file`): a FIFO, a device or a socket is refused without blocking (exit 2).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from vinecli.errors import InputError, OutputError

__all__ = [
    "Input", "InputSet", "current_inputs", "file_kind", "note_input", "open_input", "read_input_text", "reading_inputs",
    "require_regular_file",
]


@dataclass(frozen=True)
class Input:
    """One input: the path as given, where it resolves to, and what it is (for the error line)."""

    path: Path
    resolved: Path
    what: str


def _resolved(path: Path) -> Path:
    try:
        return path.resolve()
    except (OSError, RuntimeError):  # a symlink loop: compare the absolute path
        return Path(os.path.abspath(path))


class InputSet:
    """The inputs of one command or library function (resolved paths, first noted wins). A set opened
    inside another (``parent``) passes what it notes up, and its checks cover the parent's inputs too."""

    def __init__(self, parent: InputSet | None = None) -> None:
        self._items: dict[Path, Input] = {}
        self.parent = parent

    def add(self, path: str | Path, what: str = "input") -> None:
        """Note ``path`` (a file or a folder) as read."""
        p = Path(path)
        r = _resolved(p)
        self._items.setdefault(r, Input(p, r, what))
        if self.parent is not None:
            self.parent.add(p, what)

    def __iter__(self) -> Iterator[Input]:
        return iter(list(self._items.values()))

    def __len__(self) -> int:
        return len(self._items)

    def conflict(self, out: str | Path) -> str | None:
        """Why writing ``out`` would touch an input of this set or its parents (the line names both paths),
        or None."""
        out = Path(out)
        rout = _resolved(out)
        chain: list[Input] = []
        s: InputSet | None = self
        while s is not None:
            chain += s
            s = s.parent
        for inp in chain:
            rin = inp.resolved
            if rin == rout or _same_file(rin, rout):
                how = "is"
            elif rin.is_relative_to(rout):
                how = "contains"
            elif rout.is_relative_to(rin):
                how = "lies inside"
            else:
                continue
            return f"the output {how} the {inp.what} {inp.path}, an input (nothing written)"
        return None

    def refuse(self, out: str | Path) -> None:
        """OutputError (exit 2) if writing ``out`` would touch an input."""
        problem = self.conflict(out)
        if problem is not None:
            raise OutputError(problem, path=out)


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


_CURRENT: ContextVar[InputSet | None] = ContextVar("vinecli_inputs", default=None)


def current_inputs() -> InputSet | None:
    """The set of the command running in this context (None outside :func:`reading_inputs`)."""
    return _CURRENT.get()


def note_input(path: str | Path, what: str = "input") -> None:
    """Record ``path`` as an input of the command running now (no-op outside :func:`reading_inputs`)."""
    s = _CURRENT.get()
    if s is not None:
        s.add(path, what)


@contextmanager
def reading_inputs() -> Iterator[InputSet]:
    """Collect the inputs noted inside the block into a set of its own, passed up to the set already open in
    this context (a command's), if any."""
    s = InputSet(_CURRENT.get())
    token = _CURRENT.set(s)
    try:
        yield s
    finally:
        _CURRENT.reset(token)


_KINDS = ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a directory"))


def file_kind(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, for messages: "a FIFO", "a directory"..."""
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def require_regular_file(path: str | Path, what: str = "file") -> Path:
    """``path`` if it is a regular file (after symlinks); InputError (exit 2) naming what it is otherwise.

    For readers that hand the path to a library (GDAL, laspy): a FIFO there would block on open.
    """
    p = Path(path)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise InputError(f"{what} not found", path=p) from None
    except OSError as exc:
        raise InputError(f"cannot read {what}: {exc.strerror}", path=p) from None
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{what} is {file_kind(st.st_mode)}, not a regular file", path=p)
    return p


def open_input(path: str | Path, what: str = "file") -> IO[bytes]:
    """Open ``path`` for reading without ever blocking: opened non-blocking, then proven a regular file
    (InputError, exit 2, for a FIFO, device, socket, directory or a missing file)."""
    p = Path(path)
    try:
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise InputError(f"{what} not found", path=p) from None
    except IsADirectoryError:
        raise InputError(f"{what} is a directory, not a regular file", path=p) from None
    except OSError as exc:
        raise InputError(f"cannot read {what}: {exc.strerror}", path=p) from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        raise InputError(f"{what} is {file_kind(mode)}, not a regular file", path=p)
    os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")


def read_input_text(path: str | Path, what: str = "file", *, max_bytes: int = 256 << 20) -> str:
    """The UTF-8 text of the regular file ``path`` (see :func:`open_input`); InputError (exit 2) when it is
    not UTF-8, larger than ``max_bytes`` or unreadable. The message never quotes the file's content."""
    with open_input(path, what) as f:
        try:
            data = f.read(max_bytes + 1)
        except OSError as exc:
            raise InputError(f"cannot read {what}: {exc.strerror}", path=path) from None
    if len(data) > max_bytes:
        raise InputError(f"{what} is larger than {max_bytes >> 20} MB", path=path)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{what} is not UTF-8 text (byte {exc.start})", path=path) from None
