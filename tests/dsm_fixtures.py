"""DSM GeoTIFFs for the terrain tests, written with rasterio into tmp_path (no mocks).

Surfaces are analytic so expected heights are known exactly: a tilted plane (bilinear
resampling reproduces it exactly) or a smooth sum of sinusoids (for triangulation errors).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import rasterio
from rasterio.crs import CRS
from rasterio.transform import from_origin

REPO = Path(__file__).resolve().parents[1]
TEST_DATA = REPO / "tests" / "data"
SAMPLE_DSM = REPO / "worlds" / "sample" / "fieldimager_potato_plots_dsm_3cm_utm16n.tif"
US_FT = 1200.0 / 3937.0


def write_dsm(path: Path, z: np.ndarray, *, transform: Any, crs: str | None = None, nodata: float | None = None,
              dtype: str | None = None, band_unit: str | None = None, **extra: Any) -> Path:
    """Write a (bands, rows, cols) or (rows, cols) array as a GeoTIFF."""
    arr = z if z.ndim == 3 else z[None]
    profile = {"driver": "GTiff", "width": arr.shape[2], "height": arr.shape[1], "count": arr.shape[0],
               "dtype": dtype or arr.dtype.name, "transform": transform,
               "crs": CRS.from_user_input(crs) if crs else None, "nodata": nodata, **extra}
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(arr.astype(profile["dtype"]))
        if band_unit:
            dst.units = (band_unit,) * arr.shape[0]
    return path


def smooth(h: int, w: int, *, amp: float = 3.0, seed: int = 0) -> np.ndarray:
    """A smooth surface (m) of h×w samples: plane + a few sinusoids, random phases."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    z = 100.0 + 0.01 * x - 0.02 * y
    for _ in range(4):
        kx, ky = rng.uniform(0.005, 0.05, 2)
        z += amp * rng.uniform(0.3, 1.0) * np.sin(kx * x + ky * y + rng.uniform(0, 2 * math.pi))
    return z


def plane_dsm(path: Path, *, w: int = 129, h: int = 97, px: float = 1.0, crs: str | None = "EPSG:32633",
              x0: float = 500000.0, y0: float = 5000000.0, a: float = 200.0, bx: float = 0.05, by: float = -0.03,
              dtype: str = "float32", z_scale: float = 1.0, **kw: Any) -> Path:
    """z = (a + bx·X + by·Y) / z_scale at pixel centres (X, Y relative to the raster's top-left corner)."""
    cols = (np.arange(w) + 0.5) * px
    rows = (np.arange(h) + 0.5) * px
    z = (a + bx * cols[None, :] - by * rows[:, None]) / z_scale
    return write_dsm(path, z.astype(np.float64), transform=from_origin(x0, y0, px, px), crs=crs, dtype=dtype, **kw)


def plane_value(x: np.ndarray, y: np.ndarray, *, x0: float = 500000.0, y0: float = 5000000.0, a: float = 200.0,
                bx: float = 0.05, by: float = -0.03) -> np.ndarray:
    """The plane of :func:`plane_dsm` at CRS coordinates (x, y)."""
    return a + bx * (x - x0) + by * (y - y0)


def sentinel_float64_dsm(path: Path) -> tuple[Path, np.ndarray]:
    """float64, nodata -1.7e308 (overflows to -inf in float32), holes in the interior and top row; no CRS issues."""
    z = smooth(65, 81, seed=3)
    holes = np.zeros(z.shape, bool)
    holes[20:26, 30:37] = True
    holes[0, :15] = True
    z[holes] = -1.7e308
    write_dsm(path, z, transform=from_origin(600000.0, 4900000.0, 0.5, 0.5), crs="EPSG:32633", nodata=-1.7e308,
              dtype="float64")
    return path, holes


def nan_compound_dsm(path: Path) -> tuple[Path, np.ndarray]:
    """float32 EPSG:7415 (RD New + NAP) with NaN nodata holes, like the AHN sample."""
    z = smooth(80, 96, seed=5).astype(np.float32)
    holes = np.zeros(z.shape, bool)
    holes[30:45, 40:50] = True
    holes[:, -3:] = True
    z[holes] = np.nan
    write_dsm(path, z, transform=from_origin(73410.0, 451653.5, 0.5, 0.5), crs="EPSG:7415", nodata=float("nan"))
    return path, holes


def geographic_int16_dsm(path: Path, *, w: int = 121, h: int = 101, res: float = 1 / 1200) -> Path:
    """int16 heights in EPSG:4326, 3 arc-second pixels (~78 x 93 m), nodata -32768 in one corner."""
    z = np.rint(smooth(h, w, amp=20.0, seed=7)).astype(np.int16)
    z[:3, :3] = -32768
    return write_dsm(path, z, transform=from_origin(-97.4, 32.7, res, res), crs="EPSG:4326", nodata=-32768,
                     dtype="int16")


def geographic_plane_dsm(path: Path, *, lat0: float = 44.0, lon0: float = 8.0, res: float = 1e-5,
                         w: int = 129, h: int = 129) -> tuple[Path, float, float]:
    """float32 EPSG:4326 plane z = 50 + 0.01·E + 0.02·N (E, N metres from the centre, local metres per degree)."""
    from vinecli.geo import GeoOrigin

    lon_c, lat_c = lon0 + w * res / 2, lat0 - h * res / 2
    m_lat, m_lon = GeoOrigin(lat_c, lon_c, 0.0).metres_per_degree
    lons = lon0 + (np.arange(w) + 0.5) * res
    lats = lat0 - (np.arange(h) + 0.5) * res
    e = (lons - lon_c) * m_lon
    n = (lats - lat_c) * m_lat
    z = 50.0 + 0.01 * e[None, :] + 0.02 * n[:, None]
    write_dsm(path, z, transform=from_origin(lon0, lat0, res, res), crs="EPSG:4326", dtype="float32")
    return path, lat_c, lon_c


def shared_dsms() -> list[Path]:
    """Every DSM of ../shared/data/dsm (empty on a fresh clone)."""
    from repo_paths import shared_files

    return shared_files("dsm", "*.tif")


def real_dsms() -> dict[str, Path]:
    """Real DSMs by file name: ../shared/data/dsm when present, else the committed copies."""
    files = {p.name: p for p in sorted(TEST_DATA.glob("*.tif"))}
    files[SAMPLE_DSM.name] = SAMPLE_DSM
    for p in shared_dsms():
        files[p.name] = p
    return dict(sorted(files.items()))
