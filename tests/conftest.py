"""Shared fixtures: repository paths and the optional ../shared data folder."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import pytest
from repo_paths import REPO, SHARED_DATA, TEST_DATA, shared_files  # noqa: F401 (re-exported)
from shared_builds import built_once

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


def _build_world(spec: Path) -> Callable[[Path], object]:
    def build(out: Path) -> object:
        from vinecli.world import build_world

        return build_world(spec, out)
    return build


@pytest.fixture(scope="session")
def flat_world_dir(tmp_path_factory: pytest.TempPathFactory, repo: Path) -> Path:
    """worlds/flat.yaml built once per session, for every xdist worker (read-only: tests write their runs elsewhere)."""
    return built_once(tmp_path_factory, "flat", _build_world(repo / "worlds" / "flat.yaml"))


@pytest.fixture(scope="session")
def sample_world_dir(tmp_path_factory: pytest.TempPathFactory, repo: Path) -> Path:
    """worlds/vineyard-sample.yaml (the CI missions' world) built once per session, for every xdist worker
    (read-only)."""
    return built_once(tmp_path_factory, "vineyard-sample", _build_world(repo / "worlds" / "vineyard-sample.yaml"))


#: fixtures that start a real firmware (tests/px4/real_px4.py, tests/ardupilot/real_ardupilot.py)
FIRMWARE_FIXTURES = {"px4_bin", "real_px4", "ardupilot_bin"}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Under pytest-xdist (``--dist loadgroup``): the tests of a module that shares a module- or class-scoped
    fixture run on one worker (the fixture is made once, not once per worker); every other test goes wherever a
    worker is free. The firmware tests (real PX4 and ArduPilot SITL, some beside a CPU hog) run one after the
    other on one worker, as on a machine of their own."""
    for item in items:
        if item.get_closest_marker("xdist_group") is not None:
            continue
        if (item.get_closest_marker("px4") or item.get_closest_marker("ardupilot")
                or FIRMWARE_FIXTURES & set(getattr(item, "fixturenames", ()))):
            item.add_marker(pytest.mark.xdist_group("firmware"))
            continue
        info = getattr(item, "_fixtureinfo", None)
        defs = info.name2fixturedefs.values() if info is not None else ()
        if any(d[-1].scope in ("module", "class") for d in defs if d):
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::", 1)[0]))
