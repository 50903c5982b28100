"""Temporary folders vinecli makes in the system's temporary directory, and the sweep of those a killed vinecli left.

A firmware's working directory and the files a firmware run keeps (``vinecli-px4-*``, ``vinecli-ardupilot-*``,
``vinecli-firmware-*``) are made by :func:`scratch_dir`, named after their owner: ``vinecli-KIND-PID.START-XXXX``
(the process id and its start time, :func:`vinecli.lifeline.owner_tag`). A run removes its own at its end; a run
killed with ``kill -9`` cannot, so every vinecli start calls :func:`sweep_scratch`, which removes those whose owner
is gone (its pid dead, or now another process), and the firmware instance lock files no process holds. A live
vinecli's folders are never touched, nor folders named otherwise (another program's, or an older vinecli's without an
owner in the name).

The command-line process also lists the folders it writes outputs into (:func:`note_output_folder`, in
``vinecli-outputs-PID.START.list``, removed at its exit): after a ``kill -9`` the next start finds the list of a gone
owner (:func:`gone_writers`) and sweeps those folders of what it left (:func:`vinecli.outputs.sweep_gone_writers`).
"""

from __future__ import annotations

import atexit
import os
import re
import shutil
import tempfile
from pathlib import Path

from vinecli.lifeline import owner_alive, owner_tag
from vinecli.locks import remove_if_free

__all__ = ["SCRATCH_KINDS", "gone_writers", "list_outputs", "note_output_folder", "scratch_dir", "sweep_scratch"]

#: the kinds of temporary folders vinecli makes
SCRATCH_KINDS = ("firmware", "px4", "ardupilot")
#: only names with both the pid and the start time: an older vinecli's ``vinecli-px4-10-XXXX`` (10 is an instance
#: number) is never taken for an owner
_NAME = re.compile(rf"vinecli-(?:{'|'.join(SCRATCH_KINDS)})-(?P<pid>\d+)\.(?P<start>\d+)-[A-Za-z0-9_]+")


def scratch_dir(kind: str) -> Path:
    """A new folder ``$TMPDIR/vinecli-KIND-PID.START-XXXX`` owned by this process (see the module docstring)."""
    if kind not in SCRATCH_KINDS:
        raise ValueError(f"unknown scratch kind {kind!r}")
    return Path(tempfile.mkdtemp(prefix=f"vinecli-{kind}-{owner_tag()}-"))


def sweep_scratch(root: Path | None = None) -> list[Path]:
    """Remove the scratch folders in ``root`` (default: the system's temporary directory) whose owner is gone, and the
    firmware instance lock files no process holds (their folder too, once empty); returns what was removed. Cheap:
    one listing of ``root`` and one /proc read per vinecli folder."""
    root = Path(tempfile.gettempdir()) if root is None else Path(root)
    removed: list[Path] = []
    try:
        candidates = list(root.glob("vinecli-*-*"))
        lock_dirs = [root / f"vinecli-{kind}" for kind in ("px4", "ardupilot")]
    except OSError:
        return removed
    for d in lock_dirs:
        for lock in d.glob("instance-*.lock") if d.is_dir() and not d.is_symlink() else []:
            if remove_if_free(lock, marked=True):
                removed.append(lock)
        try:
            d.rmdir()
        except OSError:
            pass  # absent, or a live run's lock in it
    for p in candidates:
        m = _NAME.fullmatch(p.name)
        if m is None or p.is_symlink() or not p.is_dir():
            continue
        if owner_alive(int(m["pid"]), int(m["start"])):
            continue
        shutil.rmtree(p, ignore_errors=True)
        removed.append(p)
    return removed


#: the list of output folders this process writes into (None: not listing; the CLI turns it on)
_LIST: Path | None = None
_NOTED: set[str] = set()


def list_outputs(root: Path | None = None) -> None:
    """From now on, :func:`note_output_folder` lists this process's output folders in the temporary directory (the
    command-line process calls it; a library user or a batch worker does not), the list removed at exit."""
    global _LIST
    root = Path(tempfile.gettempdir()) if root is None else Path(root)
    _LIST = root / f"vinecli-outputs-{owner_tag()}.list"
    _NOTED.clear()
    atexit.register(_LIST.unlink, missing_ok=True)


def note_output_folder(folder: Path) -> None:
    """Add ``folder`` (where an output, its temporary sibling and its lock go) to this process's list, if it keeps
    one (:func:`list_outputs`)."""
    if _LIST is None:
        return
    key = str(Path(folder).resolve())
    if key in _NOTED:
        return
    _NOTED.add(key)
    try:
        with open(_LIST, "a", encoding="utf-8") as f:
            f.write(key + "\n")
    except OSError:
        pass  # a full or read-only temporary directory: the next writer of the folder still sweeps it


_LIST_NAME = re.compile(r"vinecli-outputs-(?P<pid>\d+)\.(?P<start>\d+)\.list")


def gone_writers(root: Path | None = None) -> list[tuple[Path, list[Path]]]:
    """The lists of output folders of vinecli processes that are gone (killed: their exit did not remove them), with
    the folders each names."""
    root = Path(tempfile.gettempdir()) if root is None else Path(root)
    out: list[tuple[Path, list[Path]]] = []
    for p in root.glob("vinecli-outputs-*.list"):
        m = _LIST_NAME.fullmatch(p.name)
        if m is None or p.is_symlink() or owner_alive(int(m["pid"]), int(m["start"])):
            continue
        try:
            if p.stat().st_uid != os.getuid():
                continue  # another user's list (the temporary directory is shared): not ours to act on
            with p.open(encoding="utf-8") as f:
                text = f.read(1 << 20)  # a real list names a few folders; a planted huge file is not read whole
            folders = [Path(line) for line in text.splitlines()[:10_000] if line.startswith("/")]
        except (OSError, UnicodeDecodeError):
            folders = []
        out.append((p, folders))
    return out
