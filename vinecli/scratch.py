"""Temporary folders vinecli makes in the system's temporary directory, and the sweep of those a killed vinecli left.

A firmware's working directory and the files a firmware run keeps (``vinecli-px4-*``, ``vinecli-ardupilot-*``,
``vinecli-firmware-*``) are made by :func:`scratch_dir`, named after their owner: ``vinecli-KIND-PID.START-XXXX``
(the process id and its start time, :func:`vinecli.lifeline.owner_tag`). A run removes its own at its end; a run
killed with ``kill -9`` cannot, so every vinecli start calls :func:`sweep_scratch`, which removes those whose owner
is gone (its pid dead, or now another process). A live vinecli's folders are never touched, nor folders named
otherwise (another program's, or an older vinecli's without an owner in the name).
"""

from __future__ import annotations

import re
import shutil
import tempfile
from pathlib import Path

from vinecli.lifeline import owner_alive, owner_tag

__all__ = ["SCRATCH_KINDS", "scratch_dir", "sweep_scratch"]

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
    """Remove the scratch folders in ``root`` (default: the system's temporary directory) whose owner is gone;
    returns what was removed. Cheap: one listing of ``root`` and one /proc read per vinecli folder."""
    root = Path(tempfile.gettempdir()) if root is None else Path(root)
    removed: list[Path] = []
    try:
        candidates = list(root.glob("vinecli-*-*"))
    except OSError:
        return removed
    for p in candidates:
        m = _NAME.fullmatch(p.name)
        if m is None or p.is_symlink() or not p.is_dir():
            continue
        if owner_alive(int(m["pid"]), int(m["start"])):
            continue
        shutil.rmtree(p, ignore_errors=True)
        removed.append(p)
    return removed
