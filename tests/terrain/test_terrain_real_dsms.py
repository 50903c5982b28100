"""Every real DSM (committed copies, the bundled sample, and ../shared/data/dsm when present) goes
through ``convert --to heightmap``, ``convert --to tiles`` and ``info``; heights are checked
against gdalwarp and the tiles against downward rays in PyBullet."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
import rasterio
from dsm_fixtures import SAMPLE_DSM, TEST_DATA, real_dsms, shared_dsms
from scipy import ndimage
from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.terrain.heightmap import load_heightmap
from vinecli.terrain.raster import valid_mask
from vinecli.terrain.tiles import load_tiles

from .test_terrain_tiles import assert_rays_within_error

DSMS = real_dsms()


def test_real_data_present() -> None:
    """The committed copies exist (tests must pass without ../shared) and match ../shared when present."""
    for name in ("pysheds_dem_3arcsec_epsg4326_int16.tif", "lidr_dtm_1m_float64_nocrs.tif",
                 "ahn_lidar_dsm_0p5m_rdnew_nap.tif"):
        assert (TEST_DATA / name).is_file()
    assert SAMPLE_DSM.is_file()
    readme = (TEST_DATA / "README.md").read_text()
    for name in ("pysheds_dem_3arcsec_epsg4326_int16.tif", "lidr_dtm_1m_float64_nocrs.tif",
                 "ahn_lidar_dsm_0p5m_rdnew_nap.tif"):
        assert name in readme  # attribution row
    for p in shared_dsms():
        assert p.name in DSMS  # every shared DSM is in the parametrised set below


@pytest.mark.parametrize("src", list(DSMS.values()), ids=list(DSMS))
def test_real_dsm_heightmap_matches_gdalwarp(src: Path, tmp_path: Path) -> None:
    out = tmp_path / "hm"
    r = CliRunner().invoke(app, ["terrain", "convert", str(src), "--to", "heightmap", "--size", "257", "--out",
                                 str(out)])
    assert r.exit_code == 0, r.stderr
    hm = load_heightmap(out)
    m = hm.meta
    assert np.isfinite(hm.heights).all() and hm.size == 257
    assert m["z_min"] == pytest.approx(float(hm.heights.min())) and m["z_max"] >= m["z_min"]
    t = hm.transform
    te = [t.c, t.f + t.e * 257, t.c + t.a * 257, t.f]
    cmd = ["gdalwarp", "-q", "-r", "bilinear", "-te", *map(repr, te), "-ts", "257", "257", "-ot", "Float32",
           "-dstnodata", "nan"]
    if hm.grid_crs is not None and m["crs"] != m["grid_crs"]:
        cmd += ["-t_srs", hm.grid_crs.to_wkt()]
    subprocess.run([*cmd, str(src), str(tmp_path / "gw.tif")], check=True)
    with rasterio.open(tmp_path / "gw.tif") as ds:
        ref = ds.read(1)
    with rasterio.open(src) as ds:
        holes = ~valid_mask(ds.read(1), ds.nodata)
        # vertices far from nodata: GDAL leaves/blends holes, vinecli fills them first
        near = ndimage.binary_dilation(holes, iterations=8)
    ok = np.isfinite(ref)
    if near.any() and m["crs"] == m["grid_crs"]:
        xs = np.linspace(m["bounds"][0], m["bounds"][2], 257)
        ys = np.linspace(m["bounds"][3], m["bounds"][1], 257)
        with rasterio.open(src) as ds:
            r_idx, c_idx = rasterio.transform.rowcol(ds.transform, *np.meshgrid(xs, ys))
        r_idx = np.clip(np.asarray(r_idx).reshape(257, 257), 0, near.shape[0] - 1)
        c_idx = np.clip(np.asarray(c_idx).reshape(257, 257), 0, near.shape[1] - 1)
        ok &= ~near[r_idx, c_idx]
    assert ok.mean() > 0.8
    d = hm.heights[ok] - ref[ok]
    scale = m["units"]["z_to_m"]
    assert scale == 1.0
    assert np.sqrt(np.mean(d**2)) < 1e-3 and np.abs(d).max() < 0.01


@pytest.mark.parametrize("src", list(DSMS.values()), ids=list(DSMS))
def test_real_dsm_tiles_rays_in_pybullet(src: Path, tmp_path: Path) -> None:
    out = tmp_path / "tiles"
    r = CliRunner().invoke(app, ["terrain", "convert", str(src), "--to", "tiles", "--max-error", "0.1",
                                 "--tile-px", "256", "--out", str(out)])
    assert r.exit_code == 0, r.stderr
    ts = load_tiles(out)
    assert ts.meta["totals"]["max_error_m"] <= 0.1 and ts.meta["totals"]["max_border_gap_m"] == 0.0
    assert all(t.max_error_m <= 0.1 for t in ts.tiles)
    with rasterio.open(src) as ds:
        w, h = ds.width, ds.height
    assert ts.meta["raster_size_px"] == [w, h]  # the whole raster is tiled, not a square
    assert_rays_within_error(src, ts, n_rays=2000)


@pytest.mark.parametrize("src", list(DSMS.values()), ids=list(DSMS))
def test_real_dsm_info(src: Path) -> None:
    r = CliRunner().invoke(app, ["terrain", "info", str(src), "--json"])
    assert r.exit_code == 0, r.stderr
    f = json.loads(r.stdout)
    with rasterio.open(src) as ds:
        z = ds.read(1)
        valid = valid_mask(z, ds.nodata)
        assert f["size_px"] == [ds.width, ds.height]
    assert f["nodata_fraction"] == pytest.approx(1 - valid.mean(), abs=1e-9)
    assert f["z_min_m"] == pytest.approx(float(z[valid].min()), abs=1e-4)
    assert f["z_max_m"] == pytest.approx(float(z[valid].max()), abs=1e-4)
    hm = f["convert"]["heightmap"]
    assert hm["suggested_size"] in (129, 257, 513, 1025) and hm["pybullet_ok"]
    assert hm["square_crop_m"] <= min(f["extent_m"]) + 1e-6
    r = CliRunner().invoke(app, ["terrain", "info", str(src)])
    assert r.exit_code == 0 and "PyBullet heightfield" in r.stdout and "convert heightmap" in r.stdout
