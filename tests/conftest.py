"""Shared fixtures: repository paths and the optional ../shared data folder."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from repo_paths import REPO, SHARED_DATA, TEST_DATA, shared_files  # noqa: F401 (re-exported)

import vinecli  # noqa: F401 - first: pins numpy's CPU dispatch before numpy loads (vinecli/__init__.py)

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


@pytest.fixture(scope="session")
def flat_world_dir(tmp_path_factory: pytest.TempPathFactory, repo: Path) -> Path:
    """worlds/flat.yaml built once per session (read-only: tests write their runs elsewhere)."""
    from vinecli.world import build_world

    return build_world(repo / "worlds" / "flat.yaml", tmp_path_factory.mktemp("w") / "flat")


@pytest.fixture(scope="session")
def sample_world_dir(tmp_path_factory: pytest.TempPathFactory, repo: Path) -> Path:
    """worlds/vineyard-sample.yaml (the CI missions' world) built once per session (read-only)."""
    from vinecli.world import build_world

    return build_world(repo / "worlds" / "vineyard-sample.yaml", tmp_path_factory.mktemp("w") / "vineyard-sample")
