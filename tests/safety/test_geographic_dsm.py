"""A DSM in a geographic CRS (EPSG:4326, degrees) is reprojected onto a local metric grid, not
refused and not an internal error. The fine case: the sample
vineyard's 3 cm survey warped to EPSG:4326 (0.03 m ≈ 2.9e-7 degrees per pixel) gives the same rows as the survey
in its own UTM zone, and converts to a heightmap with its spacing in metres."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from attack_kit import SAMPLE_DSM, cli, fingerprint
from pyproj import Transformer
from rasterio.warp import Resampling, calculate_default_transform, reproject
from shapely.geometry import LineString


@pytest.fixture(scope="module")
def dsm_4326(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sample survey warped to WGS84 longitude/latitude at its own resolution (bilinear, nodata kept)."""
    out = tmp_path_factory.mktemp("geo") / "survey_epsg4326.tif"
    with rasterio.open(SAMPLE_DSM) as src:
        transform, w, h = calculate_default_transform(src.crs, "EPSG:4326", src.width, src.height, *src.bounds)
        profile = {**src.profile, "crs": "EPSG:4326", "transform": transform, "width": w, "height": h,
                   "nodata": -9999.0, "dtype": "float32"}
        with rasterio.open(out, "w", **profile) as dst:
            reproject(rasterio.band(src, 1), rasterio.band(dst, 1), dst_nodata=-9999.0, resampling=Resampling.bilinear)
    return out


def _rows_utm(geojson: Path) -> list[LineString]:
    to_utm = Transformer.from_crs("EPSG:4326", "EPSG:32616", always_xy=True)
    fc = json.loads(geojson.read_text())
    return [LineString([to_utm.transform(*c) for c in f["geometry"]["coordinates"]]) for f in fc["features"]]


def test_a_fine_dsm_in_epsg_4326_gives_the_rows_of_the_survey_in_utm(dsm_4326: Path, tmp_path: Path) -> None:
    with rasterio.open(dsm_4326) as ds:
        assert ds.crs.is_geographic and ds.res[0] < 1e-6  # degrees, ~3 cm
    before = fingerprint(dsm_4326)
    r = cli("plan", "rows", dsm_4326, "--out", tmp_path / "geo.plan")
    assert r.exit_code == 0, r.output
    r = cli("plan", "rows", SAMPLE_DSM, "--out", tmp_path / "utm.plan")
    assert r.exit_code == 0, r.output
    geo, utm = _rows_utm(tmp_path / "geo.rows.geojson"), _rows_utm(tmp_path / "utm.rows.geojson")
    assert len(geo) == len(utm) == 16
    # the same lines: each row's middle (UTM survey) within 5 cm of the row found on the geographic DSM (the
    # ends differ by the warped raster's nodata corners)
    offsets = [g.distance(u.interpolate(0.5, normalized=True)) for g, u in zip(geo, utm, strict=True)]
    assert max(offsets) < 0.05, np.round(offsets, 3)
    assert fingerprint(dsm_4326) == before


def test_a_fine_dsm_in_epsg_4326_converts_on_a_metric_grid(dsm_4326: Path, tmp_path: Path) -> None:
    r = cli("terrain", "convert", dsm_4326, "--to", "heightmap", "--size", "257", "--out", tmp_path / "hm")
    assert r.exit_code == 0, r.output
    meta = json.loads((tmp_path / "hm" / "heightmap.json").read_text())
    assert meta["units"]["geographic"] and "Transverse_Mercator" in meta["grid_crs"]  # a local metric grid
    # the centred square of the ~21 m survey, in metres (not degrees), 256 spacings across it
    assert 15.0 < meta["size_m"][0] < 30.0 and meta["spacing_m"] == pytest.approx(meta["size_m"][0] / 256, rel=1e-6)
    with rasterio.open(tmp_path / "hm" / "heightmap.tif") as ds:
        assert ds.crs.is_projected and ds.crs.linear_units in ("metre", "meter")
