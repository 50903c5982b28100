"""Synthetic run directories (tests/report/synth_runs.py) shared by the report tests.

Session-scoped: each batch is generated once; tests that modify a batch copy it first.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from .synth_runs import write_ci_batch


@pytest.fixture(scope="session")
def ci_runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The four chapter-5 missions, every check passing, with batch.json."""
    return write_ci_batch(tmp_path_factory.mktemp("runs") / "ci")


@pytest.fixture(scope="session")
def failing_runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Same batch, but gust's holds_position bound tightened to 0.1 m (measured ~0.25 m) so it fails."""
    return write_ci_batch(tmp_path_factory.mktemp("runs") / "failing",
                          fail={"gust": {"holds_position": {"bound": 0.1}}})


@pytest.fixture(scope="session")
def drifting_runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Same batch, gust drifting 0.5 m instead of 0.25 m: every check still passes, position error regressed."""
    return write_ci_batch(tmp_path_factory.mktemp("runs") / "drifting", gust_hold_error_m=0.5)


@pytest.fixture()
def runs_copy(ci_runs: Path, tmp_path: Path) -> Path:
    """A private copy of the passing batch (for corrupting)."""
    dst = tmp_path / "runs"
    shutil.copytree(ci_runs, dst)
    return dst
