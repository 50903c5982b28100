"""Fixtures for the simulation tests: built worlds (flat, synthetic bumpy DSM as tiles and heightmap)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from shared_builds import built_once
from sim_helpers import world_yaml


@pytest.fixture()
def flat_world(flat_world_dir: Path) -> Any:
    from vinecli.world import load_world

    return load_world(flat_world_dir)


def _write_bumpy_dsm(folder: Path) -> Path:
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
