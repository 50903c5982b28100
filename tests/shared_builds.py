"""Build once per test session, whichever pytest-xdist worker asks first (``make test`` runs the suite on several
workers): :func:`built_once` builds into a folder all workers of the session share, under a file lock, and every
worker gets the same folder (read-only for the tests: a test that changes it copies it first)."""

from __future__ import annotations

import fcntl
import os
from collections.abc import Callable
from pathlib import Path

import pytest

__all__ = ["built_once", "session_folder"]


def session_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The temporary folder every worker of this test session shares (the controller's; a worker's own base
    folder lies inside it)."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def built_once(tmp_path_factory: pytest.TempPathFactory, name: str, build: Callable[[Path], object]) -> Path:
    """``build(folder)`` once per session for ``name`` (a file-system name): the first worker builds while the
    others wait; a build that failed is tried again by the next one that asks. Returns the folder."""
    root = session_folder(tmp_path_factory) / "built-once"
    root.mkdir(exist_ok=True)
    out, done = root / name, root / f"{name}.done"
    with (root / f"{name}.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes, or the process dies
        if not done.exists():
            build(out)
            done.touch()
    return out
