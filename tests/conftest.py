"""Fixtures several test folders share (each folder's own live in its conftest): repository paths and the
optional ../shared data folder, built worlds (flat, the vineyard sample, a bumpy DSM as tiles and as a heightmap),
and for the MAVLink and firmware tests free loopback ports and a flat world made without ``world build``."""

from __future__ import annotations

import math
import os
import socket
from pathlib import Path
from typing import TYPE_CHECKING

import pytest
from repo_paths import REPO, SHARED_DATA, TEST_DATA, shared_files  # noqa: F401 (re-exported)

import vinecli  # noqa: F401 - first: pins numpy's CPU dispatch before numpy loads (vinecli/__init__.py)

if TYPE_CHECKING:
    from vinecli.world import World

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


@pytest.fixture(scope="session")
def bumpy_dsm(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A synthetic DSM GeoTIFF (UTM 32N, 0.1 m pixels, 24 m × 24 m) with rows of 0.4 m ridges on a slope."""
    import numpy as np
    import rasterio
    from rasterio.transform import from_origin

    n = 241
    x = np.arange(n) * 0.1
    X, Y = np.meshgrid(x, x)
    z = 400.0 + 0.02 * X + 0.01 * Y + 0.2 * (1 + np.sin(2 * math.pi * X / 2.5))
    path = tmp_path_factory.mktemp("dsm") / "bumpy.tif"
    with rasterio.open(path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32632",
                       transform=from_origin(465000.0, 5250000.0, 0.1, 0.1), nodata=-9999.0) as ds:
        z = z.astype(np.float32)
        z[5, 7] = -9999.0  # one nodata pixel, filled by the reader
        ds.write(z, 1)
    return path


@pytest.fixture(scope="session")
def bumpy_worlds(tmp_path_factory: pytest.TempPathFactory, bumpy_dsm: Path) -> dict[str, Path]:
    """The bumpy DSM built as mesh tiles and as a 129² heightmap."""
    from sim_helpers import world_yaml

    from vinecli.world import build_world

    out = {}
    for fmt, extra in (("tiles", {"max_error_m": 0.02, "tile_px": 64}), ("heightmap", {"size": 129})):
        tmp = tmp_path_factory.mktemp(fmt)
        spec = world_yaml(tmp, {"type": "dsm", "path": str(bumpy_dsm), "format": fmt, **extra},
                          spawn={"x_m": 1.0, "y_m": -2.0})
        out[fmt] = build_world(spec, tmp / "world")
    return out


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
