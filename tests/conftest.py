"""Fixtures several test folders share (each folder's own live in its conftest): repository paths and the
optional ../shared data folder, built worlds (flat, the vineyard sample, a bumpy DSM as tiles and as a heightmap),
and for the MAVLink and firmware tests free loopback ports and a flat world made without ``world build``."""

from __future__ import annotations

import math
import os
import socket
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from repo_paths import REPO, SHARED_DATA, TEST_DATA, shared_files  # noqa: F401 (re-exported)
from shared_builds import built_once

import vinecli  # noqa: F401 - first: pins numpy's CPU dispatch before numpy loads (vinecli/__init__.py)

if TYPE_CHECKING:
    from vinecli.world import World

# Headless, single-threaded numerics: deterministic and no oversubscription on 2 cores.
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("VINECLI_CACHE_DIR", "off")  # the report cache: only its own tests use one (tmp_path)


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


def _write_bumpy_dsm(folder: Path) -> Path:
    import numpy as np
    import rasterio
    from rasterio.transform import from_origin

    n = 241
    x = np.arange(n) * 0.1
    X, Y = np.meshgrid(x, x)
    z = 400.0 + 0.02 * X + 0.01 * Y + 0.2 * (1 + np.sin(2 * math.pi * X / 2.5))
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "bumpy.tif"
    with rasterio.open(path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32632",
                       transform=from_origin(465000.0, 5250000.0, 0.1, 0.1), nodata=-9999.0) as ds:
        z = z.astype(np.float32)
        z[5, 7] = -9999.0  # one nodata pixel, filled by the reader
        ds.write(z, 1)
    return path


@pytest.fixture(scope="session")
def bumpy_dsm(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A synthetic DSM GeoTIFF (UTM 32N, 0.1 m pixels, 24 m × 24 m) with rows of 0.4 m ridges on a slope."""
    return built_once(tmp_path_factory, "bumpy-dsm", _write_bumpy_dsm) / "bumpy.tif"


def _build_bumpy_worlds(dsm: Path) -> Callable[[Path], object]:
    def build(folder: Path) -> object:
        from sim_helpers import world_yaml

        from vinecli.world import build_world

        for fmt, extra in (("tiles", {"max_error_m": 0.02, "tile_px": 64}), ("heightmap", {"size": 129})):
            tmp = folder / fmt
            tmp.mkdir(parents=True, exist_ok=True)
            spec = world_yaml(tmp, {"type": "dsm", "path": str(dsm), "format": fmt, **extra},
                              spawn={"x_m": 1.0, "y_m": -2.0})
            build_world(spec, tmp / "world")
        return folder
    return build


@pytest.fixture(scope="session")
def bumpy_worlds(tmp_path_factory: pytest.TempPathFactory, bumpy_dsm: Path) -> dict[str, Path]:
    """The bumpy DSM built as mesh tiles and as a 129² heightmap, once per session for every xdist worker."""
    folder = built_once(tmp_path_factory, "bumpy-worlds", _build_bumpy_worlds(bumpy_dsm))
    return {fmt: folder / fmt / "world" for fmt in ("tiles", "heightmap")}


def _xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    """Under pytest-xdist (``make test``: ``-n auto``): the tests of a module run on one worker (its module-scoped
    fixtures are made once, not once per worker) and each firmware's real-firmware tests (tests/xdist_scopes.py)
    one after the other on one worker; the longest scopes start first (their seconds in a measured run,
    tests/scope_seconds.json; a scope not measured counts a second per test), and the workers take the next
    one as they finish one."""
    from xdist.scheduler import LoadScopeScheduling
    from xdist_scopes import scope_of, scope_seconds

    class ModuleScheduling(LoadScopeScheduling):
        ordered = False

        def _split_scope(self, nodeid: str) -> str:
            return scope_of(Path(str(config.rootpath)), nodeid)

        def _assign_work_unit(self, node: Any) -> None:
            if not self.ordered:  # the first call has the whole queue: longest first
                seconds = scope_seconds()
                for scope in sorted(self.workqueue, key=lambda s: seconds.get(s, len(self.workqueue[s]))):
                    self.workqueue.move_to_end(scope, last=False)
                self.ordered = True
            super()._assign_work_unit(node)

    return ModuleScheduling(config, log)


class _ModuleScheduler:
    """The plugin holding :func:`_xdist_make_scheduler`: a hook only pytest-xdist knows, so registered only when
    the xdist plugin is loaded (not with ``-p no:xdist``, nor without pytest-xdist)."""

    pytest_xdist_make_scheduler = staticmethod(_xdist_make_scheduler)


def pytest_configure(config: pytest.Config) -> None:
    if config.pluginmanager.hasplugin("xdist"):
        config.pluginmanager.register(_ModuleScheduler(), "vinecli-module-scheduler")


@pytest.fixture
def ports() -> dict[str, int]:
    """Distinct free ports: sim (TCP), api (UDP, vinecli side), px4 (UDP, PX4 side)."""
    from loopback_world import free_port

    out: dict[str, int] = {}
    while len(set(out.values())) < 3:
        out = {"sim": free_port(), "api": free_port(socket.SOCK_DGRAM), "px4": free_port(socket.SOCK_DGRAM)}
    return out


@pytest.fixture
def world(tmp_path: Path) -> World:
    """A flat world at ``loopback_world.ORIGIN`` made without ``world build`` (tests/loopback_world.py)."""
    from loopback_world import flat_world

    return flat_world(tmp_path)
