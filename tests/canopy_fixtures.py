"""A vineyard DSM with known canopy: hedges of known top, width and missing vines on a sloping ground, written
with rasterio (UTM 32N, 4 cm cells). Each cell holds the mean surface over it (4 x 4 sub-samples), as a
photogrammetric DSM averages what a pixel sees, so the hedges' edges are not snapped to the cells."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from rasterio.transform import from_origin

from tests.dsm_fixtures import write_dsm

CRS = "EPSG:32632"
X0, Y0 = 430_000.0, 4_950_000.0  # the raster's south-west corner, m (UTM 32N, Piedmont)


@dataclass(frozen=True)
class TruthRow:
    """One north-south hedge: its x (m from the raster's west edge), top above the ground, width; gaps as
    (y0, y1) m from the row's south end."""

    x_m: float
    top_m: float
    width_m: float
    gaps: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True)
class TruthField:
    rows: tuple[TruthRow, ...]
    spacing_m: float = 2.5
    length_m: float = 30.0
    margin_m: float = 4.0  # bare ground beyond the row ends
    cell_m: float = 0.04
    slope: float = 0.03  # ground rises to the north, m/m
    cross_slope: float = 0.02  # and to the east
    extra: dict[str, float] = field(default_factory=dict)

    @property
    def width_m(self) -> float:
        return self.rows[-1].x_m + self.spacing_m

    @property
    def height_m(self) -> float:
        return self.length_m + 2 * self.margin_m


TRUTH = TruthField(rows=(
    TruthRow(2.5, 1.80, 0.50, gaps=((8.0, 9.6),)),
    TruthRow(5.0, 1.60, 0.60),
    TruthRow(7.5, 2.00, 0.45, gaps=((14.0, 16.0), (24.0, 25.2))),
    TruthRow(10.0, 1.40, 0.55),
))


def write_truth_dsm(path: Path, truth: TruthField = TRUTH, *, sub: int = 4) -> Path:
    """The DSM of ``truth`` (float32 GeoTIFF)."""
    c = truth.cell_m
    nx, ny = int(round(truth.width_m / c)), int(round(truth.height_m / c))
    off = (np.arange(sub) + 0.5) / sub * c
    xs = (np.arange(nx)[:, None] * c + off[None, :]).ravel()  # sub-samples west -> east
    ys = (np.arange(ny)[:, None] * c + off[None, :]).ravel()  # south -> north
    gx, gy = np.meshgrid(xs, ys)
    z = 250.0 + truth.slope * gy + truth.cross_slope * gx
    along = gy - truth.margin_m
    for r in truth.rows:
        on = (np.abs(gx - r.x_m) <= r.width_m / 2) & (along >= 0) & (along <= truth.length_m)
        for a, b in r.gaps:
            on &= ~((along >= a) & (along <= b))
        z = np.where(on, z + r.top_m, z)
    z = z.reshape(ny, sub, nx, sub).mean(axis=(1, 3))[::-1]  # row 0 north
    return write_dsm(path, z.astype(np.float32), transform=from_origin(X0, Y0 + ny * c, c, c), crs=CRS)
