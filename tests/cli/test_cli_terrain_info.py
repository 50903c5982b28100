"""``vinecli terrain info``: rasters (facts + what convert would do), clouds delegated, bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from dsm_fixtures import TEST_DATA, geographic_int16_dsm, nan_compound_dsm, plane_dsm, write_dsm
from rasterio.transform import from_origin
from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.terrain.info import heightfield_memory_mb


def info(*args: str):
    return CliRunner().invoke(app, ["terrain", "info", *args])


def test_info_raster_json(tmp_path: Path) -> None:
    src, holes = nan_compound_dsm(tmp_path / "ahn.tif")
    r = info(str(src), "--json")
    assert r.exit_code == 0, r.stderr
    f = json.loads(r.stdout)
    assert f["kind"] == "raster" and f["size_px"] == [96, 80] and f["dtype"] == "float32"
    assert f["crs"] == "EPSG:7415" and f["crs_kind"].startswith("compound")
    assert f["nodata_fraction"] == pytest.approx(holes.mean())
    assert f["pixel_size_m"] == [0.5, 0.5] and f["extent_m"] == [48.0, 40.0]
    hm = f["convert"]["heightmap"]
    assert hm["square_crop_m"] == pytest.approx(39.5) and hm["suggested_size"] == 129
    assert hm["pybullet_heightfield_mb"] == pytest.approx(heightfield_memory_mb(129 * 129))
    assert f["convert"]["tiles"]["full_grid_triangles"] == 2 * 95 * 79


def test_info_geographic_and_table(tmp_path: Path) -> None:
    src = geographic_int16_dsm(tmp_path / "geo.tif")
    f = json.loads(info(str(src), "--json").stdout)
    assert f["units"]["geographic"] and 70 < f["pixel_size_m"][0] < 80 and 90 < f["pixel_size_m"][1] < 95
    assert "transverse Mercator" in f["convert"]["heightmap"]["grid"]
    assert f["geodetic_centre"]["lat"] == pytest.approx(32.7 - 101 / 2400)
    r = info(str(src))
    assert r.exit_code == 0
    for words in ("size", "CRS", "units", "resolution", "nodata", "z range", "convert heightmap",
                  "PyBullet heightfield", "convert tiles"):
        assert words in r.stdout


def test_info_no_crs_and_all_nodata_warn(tmp_path: Path) -> None:
    f = json.loads(info(str(plane_dsm(tmp_path / "n.tif", crs=None)), "--json").stdout)
    assert f["crs"] is None and f["geodetic_centre"] is None and any("no CRS" in w for w in f["warnings"])
    z = np.full((10, 10), -9999, np.int16)
    empty = write_dsm(tmp_path / "e.tif", z, transform=from_origin(0, 10, 1, 1), crs="EPSG:32633", nodata=-9999)
    f = json.loads(info(str(empty), "--json").stdout)
    assert f["nodata_fraction"] == 1.0 and f["z_min_m"] is None
    assert any("every pixel is nodata" in w for w in f["warnings"])


def test_heightfield_memory_estimate_follows_measurements() -> None:
    assert heightfield_memory_mb(257 * 257) == pytest.approx(132)
    assert heightfield_memory_mb(1025 * 1025) == pytest.approx(1000)
    assert 132 < heightfield_memory_mb(400 * 400) < 265


def test_info_point_cloud_is_delegated() -> None:
    cloud = TEST_DATA / "lidr_topography_als.laz"
    r = info(str(cloud), "--json")
    assert r.exit_code == 0, r.stderr
    f = json.loads(r.stdout)
    assert f["kind"] == "pointcloud" and f["points"] == 73403
    r = info(str(cloud))
    assert r.exit_code == 0 and "73403" in r.stdout.replace(",", "")


@pytest.mark.parametrize(("name", "content", "words"), [
    ("dem.asc", "ncols 2", "unknown extension"),
    ("notes.tif", "hello", "not a readable GeoTIFF"),
    ("missing.laz", None, "not found"),
])
def test_info_bad_input(tmp_path: Path, name: str, content: str | None, words: str) -> None:
    p = tmp_path / name
    if content is not None:
        p.write_text(content)
    r = info(str(p))
    assert r.exit_code == 2
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("vinecli: error:")]
    assert len(lines) == 1 and str(p) in lines[0] and words in lines[0]
