"""Shared fixtures: repository paths and the optional ../shared data folder."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
TEST_DATA = REPO / "tests" / "data"
SHARED_DATA = Path(os.environ.get("VINECLI_SHARED_DATA", REPO.parent / "shared" / "data"))

# Headless, single-threaded numerics: deterministic and no oversubscription on 2 cores.
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


@pytest.fixture(scope="session")
def repo() -> Path:
    """The repository root."""
    return REPO


@pytest.fixture(scope="session")
def test_data() -> Path:
    """tests/data (small committed fixtures with attribution)."""
    return TEST_DATA


def shared_files(sub: str, pattern: str) -> list[Path]:
    """Files of ../shared/data/<sub> matching pattern, or [] when ../shared is absent (fresh clone)."""
    d = SHARED_DATA / sub
    return sorted(d.glob(pattern)) if d.is_dir() else []
