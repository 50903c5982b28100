"""vinecli.gis.zone_index and the hostile maps a prescription may still be: the STRtree gives the zone the old
per-zone scan gave (shapely.contains_xy, the first zone wins, holes excluded); zones with the same rate may overlap,
slivers under the tolerance pass, a nested zone with another rate is refused; a rate raster's NaN cells are nodata
exactly where GDAL's mask says so."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from tests.canopy_fixtures import write_truth_dsm
from tests.prescription_fixtures import write_rate_raster, zone_rate
from vinecli.errors import InputError
from vinecli.gis.georef import Georef
from vinecli.gis.prescription import read_prescription
from vinecli.gis.zone_index import OVERLAP_TOLERANCE_M2, ZoneIndex
from vinecli.rows.dsm_canopy import DsmCanopy, measure_dsm_canopy


def _square(x: float, y: float, side: float) -> list[tuple[float, float]]:
    return [(x, y), (x + side, y), (x + side, y + side), (x, y + side)]


def test_first_zone_is_the_scans_first_zone() -> None:
    """300 random squares (overlapping, some with a hole) against 5,000 random points: the index of the first zone
    whose interior holds each point, as a scan of shapely.contains_xy over the zones in order finds it."""
    rng = np.random.default_rng(7)
    rings, holes = [], []
    for k in range(300):
        x, y, side = *rng.uniform(0, 100, 2), rng.uniform(1, 15)
        rings.append(_square(x, y, side))
        holes.append([_square(x + side / 4, y + side / 4, side / 2)] if k % 3 == 0 else [])
    px, py = rng.uniform(-5, 120, 5000), rng.uniform(-5, 120, 5000)
    px[:2], py[:2] = [rings[0][0][0], 200.0], [rings[0][0][1] + 0.5, 200.0]  # on an edge; outside everything
    scan = np.full(px.size, -1)
    for k in reversed(range(len(rings))):
        scan[shapely.contains_xy(Polygon(rings[k], holes[k]), px, py)] = k
    got = ZoneIndex(rings, holes).first_zone(px, py)
    assert (got == scan).all()
    assert (got >= 0).sum() > 1000 and (got == -1).sum() > 100


def test_overlaps_refused_only_with_different_rates_above_the_tolerance() -> None:
    """Two 10 m squares overlapping by 2 x 10 m: refused with different rates, naming both and 20.0 m²; accepted
    with the same rate; a 0.05 m sliver (0.5 m²) with different rates passes; edge neighbours pass."""
    a, b = _square(0, 0, 10), _square(8, 0, 10)
    with pytest.raises(InputError, match=r"zones 'A' and 'B' overlap by 20.0 m² with different rates \(100 and 200"):
        ZoneIndex([a, b], [[], []]).check_overlaps([100.0, 200.0], ["A", "B"], Path("z.gpkg"))
    ZoneIndex([a, b], [[], []]).check_overlaps([100.0, 100.0], ["A", "B"], Path("z.gpkg"))
    sliver = _square(9.95, 0, 10)
    assert Polygon(a).intersection(Polygon(sliver)).area < OVERLAP_TOLERANCE_M2
    ZoneIndex([a, sliver], [[], []]).check_overlaps([100.0, 200.0], ["A", "B"], Path("z.gpkg"))
    grid = [_square(i * 2.0, j * 2.0, 2.0) for i in range(20) for j in range(20)]
    ZoneIndex(grid, [[]] * len(grid)).check_overlaps(np.arange(len(grid), dtype=float), [""] * len(grid),
                                                     Path("z.gpkg"))


def test_a_zone_in_the_hole_of_another_does_not_overlap_it() -> None:
    outer, hole, island = _square(0, 0, 30), _square(10, 10, 10), _square(12, 12, 6)
    ZoneIndex([outer, island], [[hole], []]).check_overlaps([100.0, 300.0], ["outer", "island"], Path("z.gpkg"))


@pytest.fixture(scope="module")
def field(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, DsmCanopy, Georef]:
    d = tmp_path_factory.mktemp("field")
    c = measure_dsm_canopy(write_truth_dsm(d / "vineyard.tif"), base_m=0.5)
    return d / "vineyard.tif", c, Georef(c.rows.frame, c.rows.origin)


@pytest.mark.parametrize(("fill", "nodata"), [(np.nan, np.nan), (np.nan, -1.0), (np.nan, None), (np.inf, np.nan)])
def test_nan_cells_follow_gdals_mask(fill: float, nodata: float | None, field: tuple, tmp_path: Path) -> None:
    """A Web Mercator rate raster with a block of NaN (or infinite) cells over row ground: with the band's nodata
    NaN, GDAL's mask (rasterio read_masks) calls NaN cells nodata and they take the default rate; GDAL calls them
    data with nodata -1 or none, and infinite cells always: a rate that is not a number is refused naming the
    file and the count."""
    import rasterio

    _, c, g = field
    path = write_rate_raster(tmp_path / "r.tif", g)
    with rasterio.open(path, "r+") as ds:
        z = ds.read(1)
        z[: z.shape[0] // 4] = fill  # the northern quarter
        ds.nodata = nodata
        ds.write(z, 1)
    with rasterio.open(path) as ds:
        gdal_nodata = ds.read_masks(1) == 0
    odd = int((~np.isfinite(z)).sum())
    if not (nodata is not None and np.isnan(nodata) and np.isnan(fill)):
        assert not gdal_nodata.any()
        with pytest.raises(InputError, match=f"{odd} cells are not a number") as err:
            read_prescription(path, g, c.rows.detection.rows, default_lpha=90.0)
        assert "r.tif" in str(err.value)
        return
    assert (gdal_nodata == np.isnan(z)).all()
    m = read_prescription(path, g, c.rows.detection.rows, default_lpha=90.0)
    ys = np.array([-12.0, 0.0, 14.5])
    assert m.rates(np.full(3, 1.25), ys).tolist() == [zone_rate(-12.0), zone_rate(0.0), 90.0]
