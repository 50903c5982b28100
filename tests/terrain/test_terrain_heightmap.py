"""DSM -> heightmap: vertex-aligned resampling (against GDAL), nodata, CRS/units, crops, outputs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from dsm_fixtures import (
    US_FT,
    geographic_int16_dsm,
    geographic_plane_dsm,
    nan_compound_dsm,
    plane_dsm,
    plane_value,
    sentinel_float64_dsm,
    smooth,
    write_dsm,
)
from PIL import Image
from rasterio.transform import from_origin

from vinecli.errors import InputError, TerrainError
from vinecli.terrain.heightmap import (
    MAX_SAMPLES,
    build_heightmap,
    convert_to_heightmap,
    load_heightmap,
    png16,
    suggest_size,
    validate_size,
)


def vertex_xy(hm) -> tuple[np.ndarray, np.ndarray]:
    """CRS coordinates (grid_crs) of every vertex, from the sidecar bounds."""
    x0, y0, x1, y1 = hm.meta["bounds"]
    n = hm.size
    xs = np.linspace(x0, x1, n)
    ys = np.linspace(y1, y0, n)
    return np.meshgrid(xs, ys)


def gdalwarp(src: Path, hm, method: str, dst: Path, extra: list[str] | None = None) -> np.ndarray:
    """gdalwarp onto the heightmap's own grid (its GeoTIFF extent: cells centred on the vertices)."""
    t, n = hm.transform, hm.size
    te = [t.c, t.f + t.e * n, t.c + t.a * n, t.f]
    cmd = ["gdalwarp", "-q", "-overwrite", "-r", method, "-te", *map(repr, te), "-ts", str(n), str(n),
           "-ot", "Float32", *(extra or []), str(src), str(dst)]
    subprocess.run(cmd, check=True)
    with rasterio.open(dst) as ds:
        return ds.read(1)


# ---------------------------------------------------------------- size rules
@pytest.mark.parametrize("n", [3, 5, 129, 513, 1025])
def test_valid_sizes(n: int) -> None:
    validate_size(n)


@pytest.mark.parametrize(("n", "words"), [(2, "2^n+1"), (4, "2^n+1"), (100, "2^n+1"), (1024, "2^n+1"),
                                          (2049, "break silently")])
def test_invalid_sizes(n: int, words: str) -> None:
    with pytest.raises(InputError, match=r"--size") as ei:
        validate_size(n)
    assert words in str(ei.value)
    assert 1025**2 <= MAX_SAMPLES < 2049**2


def test_suggest_size() -> None:
    assert suggest_size(257) == 257 and suggest_size(258) == 513 and suggest_size(100) == 129
    assert suggest_size(20000) == 1025  # capped by PyBullet's heightfield limit


# ---------------------------------------------------------------- against GDAL and exact samples
@pytest.mark.parametrize("method", ["bilinear", "cubic", "average", "max", "nearest"])
def test_matches_gdalwarp_on_vertex_grid(tmp_path: Path, method: str) -> None:
    z = smooth(257, 257, seed=1).astype(np.float32)
    src = write_dsm(tmp_path / "s.tif", z, transform=from_origin(500000, 5000000, 1.0, 1.0), crs="EPSG:32633")
    hm = build_heightmap(src, 129, method=method)
    ref = gdalwarp(src, hm, method, tmp_path / "gw.tif")
    d = hm.heights.astype(np.float64) - ref
    assert np.sqrt(np.mean(d**2)) < 1e-4 and np.abs(d).max() < 1e-3


def test_naive_gdalwarp_crop_is_half_a_cell_off(tmp_path: Path) -> None:
    """gdalwarp -te <square> treats the square as cell *edges*: its cell centres sit half a cell inside."""
    z = smooth(257, 257, seed=2).astype(np.float32)
    src = write_dsm(tmp_path / "s.tif", z, transform=from_origin(500000, 5000000, 1.0, 1.0), crs="EPSG:32633")
    hm = build_heightmap(src, 129, method="bilinear")
    x0, y0, x1, y1 = hm.meta["bounds"]
    subprocess.run(["gdalwarp", "-q", "-r", "bilinear", "-te", *map(repr, [x0, y0, x1, y1]), "-ts", "129", "129",
                    str(src), str(tmp_path / "naive.tif")], check=True)
    with rasterio.open(tmp_path / "naive.tif") as ds:
        naive = ds.read(1)
    ours = gdalwarp(src, hm, "bilinear", tmp_path / "aligned.tif")
    rms_naive = float(np.sqrt(np.mean((hm.heights - naive) ** 2)))
    rms_aligned = float(np.sqrt(np.mean((hm.heights - ours) ** 2)))
    assert rms_naive > 100 * max(rms_aligned, 1e-6)


@pytest.mark.parametrize("method", ["nearest", "bilinear"])
def test_vertices_are_exact_samples_when_aligned(tmp_path: Path, method: str) -> None:
    """A 2^m+1 raster to a 2^n+1 heightmap: every vertex is a pixel centre, heights are the samples."""
    z = smooth(257, 257, seed=4).astype(np.float32)
    src = write_dsm(tmp_path / "s.tif", z, transform=from_origin(300000, 4000000, 0.25, 0.25), crs="EPSG:32616")
    rng = np.random.default_rng(0)
    for n in (257, 65):
        hm = build_heightmap(src, n, method=method)
        xs, ys = vertex_xy(hm)
        pick = rng.choice(n * n, 3000, replace=False)  # rasterio's sample() is slow per point
        with rasterio.open(src) as ds:
            sampled = np.array([v[0] for v in ds.sample(zip(xs.ravel()[pick], ys.ravel()[pick], strict=True))])
        step = 256 // (n - 1)
        np.testing.assert_array_equal(sampled, z[::step, ::step].ravel()[pick])
        if method == "nearest" or n == 257:
            np.testing.assert_allclose(hm.heights.ravel()[pick], sampled, atol=1e-4)
            np.testing.assert_allclose(hm.heights, z[::step, ::step], atol=1e-4)
        assert hm.meta["size_m"] == [64.0, 64.0] and hm.meta["spacing_m"] == pytest.approx(64.0 / (n - 1))


def test_plane_reproduced_exactly(tmp_path: Path) -> None:
    """Bilinear onto a finer grid reproduces a plane exactly (GDAL widens the kernel when downsampling)."""
    src = plane_dsm(tmp_path / "p.tif", w=301, h=211, px=0.7)
    hm = build_heightmap(src, 257, method="bilinear")
    xs, ys = vertex_xy(hm)
    np.testing.assert_allclose(hm.heights, plane_value(xs, ys), atol=2e-4)
    assert hm.meta["size_m"][0] == pytest.approx(210 * 0.7)  # centred square of the pixel-centre extent
    cx, cy = hm.meta["origin"]
    assert (cx, cy) == pytest.approx((500000 + 301 * 0.7 / 2, 5000000 - 211 * 0.7 / 2))
    assert hm.meta["origin_alt_m"] == pytest.approx(float(plane_value(np.array(cx), np.array(cy))), abs=2e-4)


# ---------------------------------------------------------------- nodata
def test_float64_sentinel_masked_before_downcast(tmp_path: Path) -> None:
    src, holes = sentinel_float64_dsm(tmp_path / "s64.tif")
    with rasterio.open(src) as ds:
        raw = ds.read(1)
    valid_min = raw[~holes].min()
    assert np.isinf(raw[holes].astype(np.float32)).all()  # what a naive downcast would produce
    hm = build_heightmap(src, 65, method="bilinear")
    assert np.isfinite(hm.heights).all() and hm.z_min >= valid_min - 1.0
    m = hm.meta
    assert 0 < m["nodata_filled_fraction"] < 0.05 and "inverse-distance" in m["fill_method"]
    # the crop (64 x 64 px square of pixel centres, centred) contains the interior hole (42 px)
    assert m["nodata_fraction"] == pytest.approx(42 / (64 * 65), rel=0.35)


@pytest.mark.parametrize("fill", ["nearest", "min", "123.5"])
def test_fill_methods(tmp_path: Path, fill: str) -> None:
    src, holes = nan_compound_dsm(tmp_path / "n.tif")
    hm = build_heightmap(src, 65, method="nearest", fill=fill)
    assert np.isfinite(hm.heights).all()
    if fill == "123.5":
        assert hm.z_max == pytest.approx(123.5) or (hm.heights == np.float32(123.5)).any()
    assert hm.meta["nodata_filled_fraction"] > 0


def test_all_nodata_is_terrain_error(tmp_path: Path) -> None:
    z = np.full((20, 20), -9999.0, np.float32)
    src = write_dsm(tmp_path / "empty.tif", z, transform=from_origin(0, 20, 1, 1), crs="EPSG:32633", nodata=-9999)
    with pytest.raises(TerrainError, match="nodata") as ei:
        build_heightmap(src, 9)
    assert ei.value.path == str(src)


# ---------------------------------------------------------------- CRS and units
def test_compound_epsg7415_nan_nodata(tmp_path: Path) -> None:
    from pyproj import Transformer

    src, _ = nan_compound_dsm(tmp_path / "ahn.tif")
    out = tmp_path / "hm"
    hm = convert_to_heightmap(src, out, size=65, method="average")
    m = json.loads((out / "heightmap.json").read_text())
    assert m["crs"] == "EPSG:7415" and m["grid_crs"] == "EPSG:7415"
    cx, cy = m["origin"]
    lon, lat = Transformer.from_crs("EPSG:28992", "EPSG:4326", always_xy=True).transform(cx, cy)
    assert m["geodetic_origin"]["lat"] == pytest.approx(lat, abs=1e-9)
    assert m["geodetic_origin"]["lon"] == pytest.approx(lon, abs=1e-9)
    assert m["geodetic_origin"]["alt"] == pytest.approx(float(hm.heights[32, 32]))
    with rasterio.open(out / "heightmap.tif") as ds:
        assert ds.crs.to_epsg() == 7415 and ds.read(1).shape == (65, 65)
        assert ds.xy(0, 0) == pytest.approx((m["bounds"][0], m["bounds"][3]))  # cell centre = first vertex


def test_geographic_plane_degrees_to_metres_in_x_and_y(tmp_path: Path) -> None:
    """z = 50 + 0.01 E + 0.02 N: the heightmap reproduces both slopes, so x and y are scaled correctly."""
    from vinecli.geo import GeoOrigin

    src, lat_c, lon_c = geographic_plane_dsm(tmp_path / "geo.tif")
    hm = build_heightmap(src, 257, method="bilinear")
    x, y = hm.enu_axes()
    expect = 50.0 + 0.01 * x[None, :] + 0.02 * y[:, None]
    np.testing.assert_allclose(hm.heights[1:-1, 1:-1], expect[1:-1, 1:-1], atol=1e-3)
    np.testing.assert_allclose(hm.heights, expect, atol=5e-3)  # edge vertices: on the curved outline
    m_lat, m_lon = GeoOrigin(lat_c, lon_c, 0).metres_per_degree
    # the square is the smaller of the two extents in metres (128 px of 1e-5 deg)
    assert hm.size_m == pytest.approx(min(128e-5 * m_lon, 128e-5 * m_lat), rel=2e-3)
    assert hm.origin is not None and hm.origin.lat == pytest.approx(lat_c, abs=1e-7)
    assert hm.origin.lon == pytest.approx(lon_c, abs=1e-7)
    assert "Transverse Mercator" in hm.meta["grid_crs"] or "Local TM" in hm.meta["grid_crs"]


def test_geographic_int16_matches_gdalwarp_to_local_tm(tmp_path: Path) -> None:
    src = geographic_int16_dsm(tmp_path / "dem.tif")
    hm = build_heightmap(src, 65, method="bilinear", fill="nearest")
    with rasterio.open(src) as ds:
        raw = ds.read(1)
    assert hm.z_min >= raw[raw != -32768].min() - 1 and hm.z_max <= raw.max() + 1
    ref = gdalwarp(src, hm, "bilinear", tmp_path / "gw.tif", ["-t_srs", hm.grid_crs.to_wkt(), "-dstnodata", "nan"])
    ok = np.isfinite(ref)
    ok[:4, :4] = False  # the nodata corner: we fill, GDAL leaves holes
    d = hm.heights[ok] - ref[ok]
    assert np.sqrt(np.mean(d**2)) < 0.01


def test_feet_compound_crs_to_metres(tmp_path: Path) -> None:
    """NAD83 / Texas Central (ftUS) + NAVD88 height (ftUS): spacing and heights become metres."""
    src = plane_dsm(tmp_path / "ft.tif", w=129, h=129, px=3.0, crs="EPSG:2277+6360", x0=2300000, y0=13800000,
                    z_scale=US_FT)
    hm = build_heightmap(src, 129)
    u = hm.meta["units"]
    assert u["xy_unit"] == "US survey foot" and u["z_to_m"] == pytest.approx(US_FT)
    assert u["z_source"] in ("crs-vertical-axis", "band-unit")
    assert hm.spacing_m == pytest.approx(3.0 * US_FT)
    assert hm.size_m == pytest.approx(128 * 3.0 * US_FT)
    xs, ys = vertex_xy(hm)
    np.testing.assert_allclose(hm.heights, plane_value(xs, ys, x0=2300000, y0=13800000), atol=1e-3)


def test_feet_horizontal_only_assumes_feet_heights_and_override(tmp_path: Path) -> None:
    src = plane_dsm(tmp_path / "ft2.tif", w=65, h=65, px=2.0, crs="EPSG:2277", x0=2300000, y0=13800000,
                    z_scale=US_FT)
    hm = build_heightmap(src, 65)
    assert hm.meta["units"]["z_source"] == "assumed-horizontal"
    assert any("vertical unit" in w for w in hm.meta["warnings"])
    xs, ys = vertex_xy(hm)
    np.testing.assert_allclose(hm.heights, plane_value(xs, ys, x0=2300000, y0=13800000), atol=1e-3)
    hm_m = build_heightmap(src, 65, z_unit="m")
    np.testing.assert_allclose(hm_m.heights, hm.heights / US_FT, rtol=1e-5)


def test_no_crs_warns_and_origin_is_null(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    src = plane_dsm(tmp_path / "nocrs.tif", crs=None, w=65, h=65)
    out = tmp_path / "hm"
    with caplog.at_level("WARNING", logger="vinecli"):
        hm = convert_to_heightmap(src, out, size=129)
    assert any("no CRS" in r.getMessage() for r in caplog.records)
    m = json.loads((out / "heightmap.json").read_text())
    assert m["crs"] is None and m["geodetic_origin"] is None and "unknown" in m["geodetic_origin_note"]
    assert m["units"]["xy_assumed"] is True and m["spacing_m"] == pytest.approx(0.5)
    xs, ys = vertex_xy(hm)
    np.testing.assert_allclose(hm.heights, plane_value(xs, ys), atol=2e-4)
    with rasterio.open(out / "heightmap.tif") as ds:
        assert ds.crs is None


# ---------------------------------------------------------------- crops
def test_window_crop_spans_pixel_centres(tmp_path: Path) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=200, h=150, px=1.0)
    hm = build_heightmap(src, 65, window=(10, 20, 65, 65))
    assert hm.meta["bounds"] == pytest.approx([500010.5, 5000000 - 84.5, 500074.5, 5000000 - 20.5])
    xs, ys = vertex_xy(hm)
    np.testing.assert_allclose(hm.heights, plane_value(xs, ys), atol=2e-4)
    # non-square window -> centred largest square
    hm2 = build_heightmap(src, 33, window=(0, 0, 101, 51))
    assert hm2.meta["crop"]["trimmed_to_square"] and hm2.size_m == pytest.approx(50.0)


def test_bbox_crop(tmp_path: Path) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=200, h=150, px=1.0)
    bbox = (500020.0, 4999900.0, 500084.0, 4999964.0)
    hm = build_heightmap(src, 65, bbox=bbox)
    assert hm.meta["bounds"] == pytest.approx(list(bbox)) and hm.spacing_m == pytest.approx(1.0)
    xs, ys = vertex_xy(hm)
    np.testing.assert_allclose(hm.heights, plane_value(xs, ys), atol=2e-4)


@pytest.mark.parametrize("window", [(190, 0, 20, 20), (-1, 0, 10, 10), (0, 0, 1, 10), (0, 140, 10, 11)])
def test_window_outside_raster(tmp_path: Path, window: tuple[int, int, int, int]) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=200, h=150)
    with pytest.raises(InputError, match="outside the raster") as ei:
        build_heightmap(src, 33, window=window)
    assert ei.value.path == str(src)


def test_bbox_outside_raster(tmp_path: Path) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=200, h=150)
    with pytest.raises(InputError, match="outside the raster bounds"):
        build_heightmap(src, 33, bbox=(499000.0, 4999900.0, 500050.0, 4999950.0))


# ---------------------------------------------------------------- DSM rows
def test_max_keeps_vine_row_tops(tmp_path: Path) -> None:
    """1-px rows 1.5 m high every 8 px, 4x downsampling: max keeps the tops, bilinear loses them."""
    z = np.zeros((513, 513), np.float32)
    z[:, 3::8] = 1.5
    src = write_dsm(tmp_path / "rows.tif", z, transform=from_origin(0, 513 * 0.1, 0.1, 0.1), crs="EPSG:32632")
    top = build_heightmap(src, 129, method="max")
    blur = build_heightmap(src, 129, method="bilinear")
    assert top.heights.max(axis=1).min() == pytest.approx(1.5)
    assert (top.heights == np.float32(1.5)).mean() > 0.45  # every other output column holds a row top
    assert blur.z_max < 1.0
    assert top.meta["resolution_loss"]["max_below_source_m"] < blur.meta["resolution_loss"]["max_below_source_m"]


# ---------------------------------------------------------------- outputs
def test_outputs_png16_tif_json_and_load(tmp_path: Path) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=257, h=257, px=0.5)
    out = tmp_path / "hm"
    hm = convert_to_heightmap(src, out, size=129, method="cubic")
    assert sorted(p.name for p in out.iterdir()) == ["heightmap.json", "heightmap.png", "heightmap.tif",
                                                     "manifest.json"]
    m = json.loads((out / "heightmap.json").read_text())
    for key in ("size_m", "spacing_m", "z_min", "z_max", "height_step_m", "crs", "origin", "geodetic_origin",
                "resampling", "nodata_filled_fraction", "fill_method", "source"):
        assert key in m
    assert m["source"]["name"] == "p.tif" and m["resampling"] == "cubic"
    png = Image.open(out / "heightmap.png")
    assert png.mode == "I;16" and png.size == (129, 129)
    q = np.array(png).astype(np.float64)
    assert q.min() == 0 and q.max() == 65535
    with rasterio.open(out / "heightmap.tif") as ds:
        tif = ds.read(1)
        assert ds.dtypes[0] == "float32" and ds.crs.to_epsg() == 32633
    decoded = m["z_min"] + q * m["height_step_m"]
    assert np.abs(decoded - tif).max() <= m["height_step_m"] / 2 + 1e-6
    assert m["height_step_m"] == pytest.approx((m["z_max"] - m["z_min"]) / 65535)
    loaded = load_heightmap(out)
    np.testing.assert_array_equal(loaded.heights, hm.heights)
    assert loaded.size == 129 and loaded.spacing_m == pytest.approx(1.0)
    assert loaded.origin is not None and loaded.origin.alt == pytest.approx(loaded.centre_height)
    assert loaded.heights_enu()[64, 64] == 0.0
    x, y = loaded.enu_axes()
    assert x[0] == pytest.approx(-64.0) and y[0] == pytest.approx(64.0)  # row 0 = north
    manifest = json.loads((out / "manifest.json").read_text())
    assert {o["path"] for o in manifest["outputs"]} == {"heightmap.json", "heightmap.png", "heightmap.tif"}


def test_png16_flat_and_range() -> None:
    q, lo, hi, step = png16(np.full((3, 3), 7.0, np.float32))
    assert (q == 0).all() and lo == hi == 7.0 and step == 0.0
    q, lo, hi, step = png16(np.array([[0.0, 1.0], [0.5, 0.25]], np.float32))
    assert q.tolist() == [[0, 65535], [32768, 16384]] and step == pytest.approx(1 / 65535)


def test_load_heightmap_rejects_other_dirs(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="heightmap.json"):
        load_heightmap(tmp_path)


# ---------------------------------------------------------------- large inputs: streamed, bounded memory
def test_streamed_read_matches_full_read(tmp_path: Path) -> None:
    z = smooth(513, 513, seed=9).astype(np.float32)
    z[100:110, 200:230] = -9999
    src = write_dsm(tmp_path / "big.tif", z, transform=from_origin(0, 513, 1, 1), crs="EPSG:32633", nodata=-9999)
    for method, tol in (("nearest", 1e-3), ("average", 0.02), ("max", 0.05)):
        full = build_heightmap(src, 65, method=method)
        streamed = build_heightmap(src, 65, method=method, max_read_px=1000)
        assert streamed.meta["read"].startswith("streamed") and full.meta["read"].startswith("full")
        d = streamed.heights - full.heights
        assert np.sqrt(np.mean(d**2)) < tol, method
        if method == "nearest":
            assert (np.abs(d) < 1e-4).mean() > 0.95  # differences only near the filled hole


# VmHWM (this process image's peak RSS) rather than getrusage: on Linux ru_maxrss survives exec, so a
# child spawned by a big pytest process would report the parent's peak.
_RSS_CHILD = """
import re, sys
from pathlib import Path
from vinecli.terrain.heightmap import convert_to_heightmap
hm = convert_to_heightmap(Path(sys.argv[1]), Path(sys.argv[2]), size=257, method=sys.argv[3])
print(hm.meta["read"])
print(re.search(r"VmHWM:\\s+(\\d+) kB", open("/proc/self/status").read()).group(1))
"""


def test_large_dsm_peak_memory_below_raster_size(tmp_path: Path) -> None:
    """An 8193² float32 DSM (256 MiB) -> 257²: the child's peak RSS stays well below the raster size."""
    n = 8193
    path = tmp_path / "large.tif"
    with rasterio.open(path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32633",
                       transform=from_origin(0, n * 0.25, 0.25, 0.25), tiled=True, blockxsize=512,
                       blockysize=512) as dst:
        x = np.arange(n, dtype=np.float32)
        for r0 in range(0, n, 512):
            rows = np.arange(r0, min(n, r0 + 512), dtype=np.float32)
            block = 100 + 0.001 * x[None, :] + 0.3 * np.sin(rows[:, None] * 0.01) + 0.5 * ((x[None, :] % 37) < 2)
            dst.write(block.astype(np.float32), 1, window=rasterio.windows.Window(0, r0, n, rows.size))
    raster_mib = n * n * 4 / 2**20
    r = subprocess.run([sys.executable, "-c", _RSS_CHILD, str(path), str(tmp_path / "hm"), "max"],
                       capture_output=True, text=True, check=True)
    mode, rss_kib = r.stdout.strip().splitlines()[-2:]
    assert mode.startswith("streamed")
    peak_mib = int(rss_kib) / 1024
    assert peak_mib < 0.8 * raster_mib, f"peak RSS {peak_mib:.0f} MiB for a {raster_mib:.0f} MiB raster"
    hm = load_heightmap(tmp_path / "hm")
    assert hm.z_max == pytest.approx(100 + 0.001 * (n - 1) + 0.3 + 0.5, abs=0.05)  # max kept the 2-px ridges


def test_origin_in_source_crs_and_grid_crs(tmp_path: Path) -> None:
    src, lat_c, lon_c = geographic_plane_dsm(tmp_path / "geo.tif")
    m = build_heightmap(src, 65).meta
    assert m["crs"] == "EPSG:4326" and m["origin"] == pytest.approx([lon_c, lat_c])
    assert m["origin_grid_crs"] == [0.0, 0.0]  # local TM centred on the origin
    proj = build_heightmap(plane_dsm(tmp_path / "p.tif"), 65).meta
    assert proj["origin"] == proj["origin_grid_crs"]
