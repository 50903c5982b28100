"""DSM -> mesh tiles: error bound measured independently, crack-free borders, PyBullet rays, formats."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pybullet as p
import pytest
import rasterio
import trimesh
from dsm_fixtures import geographic_int16_dsm, nan_compound_dsm, sentinel_float64_dsm, smooth, write_dsm
from pybullet_utils.bullet_client import BulletClient
from rasterio.transform import from_origin

from vinecli.errors import InputError
from vinecli.terrain.tiles import convert_to_tiles, load_tiles, split_edges
from vinecli.terrain.tin import Tin, interpolate, mesh_grid, split_border, tin_error


def raster_local(src: Path, meta: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raster heights relative to the tiles' origin and the local x/y of every pixel centre."""
    with rasterio.open(src) as ds:
        z = ds.read(1).astype(np.float64)
    h, w = z.shape
    dx, dy = meta["pixel_size_m"]
    x = (np.arange(w) - (w - 1) / 2) * dx
    y = ((h - 1) / 2 - np.arange(h)) * dy
    return z - meta["origin"]["alt_m"], x, y


def load_pybullet(ts, client: BulletClient) -> None:
    for t in ts.tiles:
        shape = client.createCollisionShape(p.GEOM_MESH, fileName=str(t.path), flags=p.GEOM_FORCE_CONCAVE_TRIMESH)
        assert shape >= 0
        body = client.createMultiBody(baseMass=0, baseCollisionShapeIndex=shape)
        lo, hi = client.getAABB(body)
        b = t.bounds_m
        assert lo[0] == pytest.approx(b[0], abs=0.05) and hi[1] == pytest.approx(b[4], abs=0.05)


def ray_heights(client: BulletClient, xs: np.ndarray, ys: np.ndarray, top: float, bottom: float) -> np.ndarray:
    out = []
    for k in range(0, xs.size, 4000):
        starts = [(float(x), float(y), top) for x, y in zip(xs[k:k + 4000], ys[k:k + 4000], strict=True)]
        ends = [(float(x), float(y), bottom) for x, y in zip(xs[k:k + 4000], ys[k:k + 4000], strict=True)]
        out += [h[3][2] if h[0] >= 0 else np.nan for h in client.rayTestBatch(starts, ends)]
    return np.array(out)


def assert_rays_within_error(src: Path, ts, n_rays: int = 3000, seed: int = 0) -> None:
    """Downward rays at random raster samples land within E of the raster (valid samples only)."""
    meta = ts.meta
    z, x, y = raster_local(src, meta)
    with rasterio.open(src) as ds:
        from vinecli.terrain.raster import valid_mask

        valid = valid_mask(ds.read(1), ds.nodata)
    rng = np.random.default_rng(seed)
    # interior samples (a ray exactly on the mesh's outer edge may graze past it), plus samples on the
    # shared tile borders, where a crack would let rays through
    r = rng.integers(1, z.shape[0] - 1, n_rays)
    c = rng.integers(1, z.shape[1] - 1, n_rays)
    border_rows = [t.entry["window_px"][1] for t in ts.tiles if t.entry["window_px"][1] > 0]
    border_cols = [t.entry["window_px"][0] for t in ts.tiles if t.entry["window_px"][0] > 0]
    k = n_rays // 10
    if border_rows:
        r[:k] = rng.choice(border_rows, k)
    if border_cols:
        c[k:2 * k] = rng.choice(border_cols, k)
    keep = valid[r, c]
    r, c = r[keep], c[keep]
    scale = meta["units"]["z_to_m"]
    zt = (z[r, c] + meta["origin"]["alt_m"]) * scale - meta["origin"]["alt_m"] if scale != 1.0 else z[r, c]
    client = BulletClient(connection_mode=p.DIRECT)
    try:
        load_pybullet(ts, client)
        lo, hi = meta["totals"]["bounds_m"][2], meta["totals"]["bounds_m"][5]
        hit = ray_heights(client, x[c], y[r], hi + 10, lo - 10)
    finally:
        client.disconnect()
    assert np.isfinite(hit).all(), "some rays missed the terrain"
    e = meta["max_error_m"] or meta["totals"]["max_error_m"]
    err = np.abs(hit - zt)
    assert err.max() <= e + 1e-3, f"ray error {err.max():.4f} > {e}"


def obj_vertices(path: Path) -> np.ndarray:
    return np.array([[float(v) for v in ln.split()[1:4]] for ln in path.read_text().splitlines()
                     if ln.startswith("v ")])


# ---------------------------------------------------------------- TIN building blocks
def test_split_edges() -> None:
    assert split_edges(2048, 256) == [256 * i for i in range(9)]
    e = split_edges(1000, 256)
    assert e[0] == 0 and e[-1] == 1000 and len(e) == 5 and max(np.diff(e)) <= 256
    assert split_edges(10, 256) == [0, 10]


def test_interpolate_reproduces_plane_and_error_is_zero() -> None:
    y, x = np.mgrid[0:65, 0:97].astype(np.float32)
    z = 3 + 0.2 * x - 0.1 * y
    tin = mesh_grid(z, 0, 0, 0.001, None)
    assert tin.tris.shape[0] == 2  # a plane needs two triangles
    np.testing.assert_allclose(interpolate(tin, z, 0, 0), z, atol=1e-5)
    mx, rms, n, unc = tin_error(tin, z, 0, 0)
    assert mx < 1e-5 and n == z.size and unc == 0


def test_mesh_orientation_up_and_pixel_positions() -> None:
    z = smooth(33, 41, seed=1).astype(np.float32)
    tin = mesh_grid(z, 100, 200, 0.01, None)
    assert tin.cols.min() == 100 and tin.cols.max() == 140 and tin.rows.min() == 200 and tin.rows.max() == 232
    x, yy = tin.cols[tin.tris].astype(float), -tin.rows[tin.tris].astype(float)
    area2 = (x[:, 1] - x[:, 0]) * (yy[:, 2] - yy[:, 0]) - (x[:, 2] - x[:, 0]) * (yy[:, 1] - yy[:, 0])
    assert (area2 > 0).all()
    # vertex heights are the grid's: pydelatin's y axis (up) was mapped back to rows (down)
    mx, _, _, _ = tin_error(tin, z, 100, 200)
    assert mx <= 0.01 + 1e-6


def test_split_border_fans_and_keeps_area() -> None:
    # unit square of 4 px: two triangles, border column 4 gets rows 1 and 3 inserted
    tin = Tin(np.array([0, 4, 4, 0]), np.array([0, 0, 4, 4]), np.array([[0, 3, 2], [0, 2, 1]]))
    out = split_border(tin, "col", 4, np.array([0, 1, 3, 4]))
    on = out.cols == 4
    assert sorted(out.rows[on].tolist()) == [0, 1, 3, 4]
    assert out.tris.shape[0] == 4
    x, y = out.cols[out.tris].astype(float), -out.rows[out.tris].astype(float)
    area2 = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    assert area2.sum() == pytest.approx(2 * 16) and (np.sign(area2) == np.sign(area2[0])).all()


# ---------------------------------------------------------------- convert --to tiles
@pytest.fixture(scope="module")
def smooth_tiles(tmp_path_factory: pytest.TempPathFactory):
    d = tmp_path_factory.mktemp("tiles")
    z = smooth(385, 513, amp=4.0, seed=11).astype(np.float32)
    src = write_dsm(d / "s.tif", z, transform=from_origin(500000, 5000000, 0.5, 0.5), crs="EPSG:32633")
    ts = convert_to_tiles(src, d / "out", max_error=0.05, tile_px=128, workers=2)
    return src, ts


def test_tiles_json_schema_and_bound(smooth_tiles) -> None:
    src, ts = smooth_tiles
    m = json.loads((ts.dir / "tiles.json").read_text())
    assert m["tile_grid"] == [3, 4] and len(m["tiles"]) == 12
    for t in m["tiles"]:
        assert (ts.dir / t["file"]).is_file() and t["file"].endswith(".obj")
        assert t["max_error_m"] <= 0.05 and 0 < t["rms_error_m"] < t["max_error_m"]
        assert t["triangles"] > 0 and len(t["bounds_m"]) == 6
        assert t["samples"] == t["window_px"][2] * t["window_px"][3]
    tot = m["totals"]
    assert tot["triangles"] == sum(t["triangles"] for t in m["tiles"]) and tot["max_error_m"] <= 0.05
    assert tot["full_grid_triangles"] == 2 * 512 * 384 and tot["max_border_gap_m"] == 0.0
    assert m["origin"]["crs_xy"] == pytest.approx([500000 + 513 * 0.25, 5000000 - 385 * 0.25])
    assert m["geodetic_origin"]["lat"] == pytest.approx(m["origin"]["geodetic"]["lat"])
    assert (ts.dir / "manifest.json").is_file()


def test_measured_error_independently(smooth_tiles) -> None:
    """Re-measure every OBJ (read back with trimesh) against the raster at every sample, with
    matplotlib's linear triangle interpolator (an implementation independent of vinecli's)."""
    from matplotlib.tri import LinearTriInterpolator, Triangulation

    src, ts = smooth_tiles
    z, x, y = raster_local(src, ts.meta)
    worst = 0.0
    for t in ts.tiles:
        mesh = trimesh.load(t.path, process=False)
        v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
        assert f.shape[0] == t.triangles
        assert (mesh.face_normals[:, 2] > 0).all()  # normals up
        interp = LinearTriInterpolator(Triangulation(v[:, 0], v[:, 1], f), v[:, 2])
        c0, r0, w, h = t.entry["window_px"]
        gx, gy = np.meshgrid(x[c0:c0 + w], y[r0:r0 + h])
        zz = interp(gx, gy)
        assert not np.ma.getmaskarray(zz).any()  # every sample covered
        err = np.abs(np.asarray(zz) - z[r0:r0 + h, c0:c0 + w])
        worst = max(worst, float(err.max()))
        assert err.max() == pytest.approx(t.max_error_m, abs=1e-4)
        assert np.sqrt(np.mean(err**2)) == pytest.approx(t.rms_error_m, rel=1e-3)
    assert worst <= 0.05


def test_crack_free_shared_border_vertices(smooth_tiles) -> None:
    _, ts = smooth_tiles
    tiles = {(t.row, t.col): t for t in ts.tiles}
    verts = {k: obj_vertices(t.path) for k, t in tiles.items()}
    checked = 0
    for (i, j), t in tiles.items():
        for di, dj, axis in ((0, 1, 0), (1, 0, 1)):
            nb = tiles.get((i + di, j + dj))
            if nb is None:
                continue
            a, b = verts[(i, j)], verts[(i + di, j + dj)]
            line = t.bounds_m[3] if axis == 0 else t.bounds_m[1]  # east edge x, or south edge y
            ea = a[np.isclose(a[:, axis], line, atol=1e-5)]
            eb = b[np.isclose(b[:, axis], line, atol=1e-5)]
            ea = ea[np.argsort(ea[:, 1 - axis])]
            eb = eb[np.argsort(eb[:, 1 - axis])]
            assert ea.shape == eb.shape and ea.shape[0] >= 2
            assert np.abs(ea - eb).max() == 0.0  # identical vertices: no T-junctions, no cracks
            checked += 1
    assert checked == 3 * 3 + 2 * 4


def test_rays_in_pybullet(smooth_tiles) -> None:
    src, ts = smooth_tiles
    assert_rays_within_error(src, ts)


def test_stitching_closes_unstitched_gaps(smooth_tiles) -> None:
    """Without the shared-vertex stitch, independent pydelatin tiles disagree along borders."""
    from vinecli.terrain.tiles import _stitch, border_gap

    src, ts = smooth_tiles
    with rasterio.open(src) as ds:
        z = ds.read(1)
    cedges, redges = split_edges(512, 128), split_edges(384, 128)
    raw = {}
    for i in range(3):
        for j in range(4):
            c0, c1, r0, r1 = cedges[j], cedges[j + 1], redges[i], redges[i + 1]
            raw[(i, j)] = mesh_grid(z[r0:r1 + 1, c0:c1 + 1], c0, r0, 0.05, None)
    before = border_gap(raw[(0, 0)], raw[(0, 1)], "col", cedges[1], z)
    stitched = _stitch(raw, cedges, redges)
    after = border_gap(stitched[(0, 0)], stitched[(0, 1)], "col", cedges[1], z)
    assert after == 0.0 and before <= 2 * 0.05


def test_nodata_geographic_and_no_crs_inputs(tmp_path: Path) -> None:
    s64, holes = sentinel_float64_dsm(tmp_path / "s64.tif")
    ts = convert_to_tiles(s64, tmp_path / "t64", max_error=0.02, tile_px=32)
    assert ts.meta["nodata_filled_fraction"] == pytest.approx(holes.mean())
    assert all(t.max_error_m <= 0.02 for t in ts.tiles)
    assert np.isfinite(ts.meta["totals"]["bounds_m"]).all() and ts.meta["totals"]["bounds_m"][2] > -50
    assert_rays_within_error(s64, ts, n_rays=1000)

    nan, _ = nan_compound_dsm(tmp_path / "nan.tif")
    ts = convert_to_tiles(nan, tmp_path / "tnan", max_error=0.05, tile_px=40)
    assert ts.meta["origin"]["crs"] == "EPSG:7415" and ts.origin is not None

    geo = geographic_int16_dsm(tmp_path / "geo.tif")
    ts = convert_to_tiles(geo, tmp_path / "tgeo", max_error=0.1, tile_px=64)
    b = ts.meta["totals"]["bounds_m"]
    dx, dy = ts.meta["pixel_size_m"]
    assert 70 < dx < 80 and 90 < dy < 95  # 3 arc-seconds at 32.7 N
    assert b[3] - b[0] == pytest.approx(120 * dx) and b[4] - b[1] == pytest.approx(100 * dy)
    assert ts.origin is not None and ts.origin.lat == pytest.approx(32.7 - 101 / 1200 / 2, abs=1e-9)
    assert_rays_within_error(geo, ts, n_rays=1000)

    z = smooth(50, 60, seed=2).astype(np.float32)
    nocrs = write_dsm(tmp_path / "nocrs.tif", z, transform=from_origin(1000, 2000, 2.0, 2.0))
    ts = convert_to_tiles(nocrs, tmp_path / "tn", max_error=0.05, tile_px=32)
    assert ts.origin is None and ts.meta["geodetic_origin"] is None and ts.meta["pixel_size_m"] == [2.0, 2.0]
    assert "no CRS" in " ".join(ts.meta["warnings"])


def test_max_triangles_budget_and_stl(tmp_path: Path) -> None:
    z = smooth(129, 129, amp=5.0, seed=3).astype(np.float32)
    src = write_dsm(tmp_path / "s.tif", z, transform=from_origin(0, 129, 1, 1), crs="EPSG:32633")
    ts = convert_to_tiles(src, tmp_path / "budget", max_triangles=200, tile_px=64, fmt="stl")
    assert ts.meta["error_bound_enforced"] is False and ts.meta["max_triangles"] == 200
    for t in ts.tiles:
        assert t.path.suffix == ".stl" and t.path.read_bytes()[:5] != b"solid"  # binary STL
        assert 200 <= t.triangles <= 260  # pydelatin stops at the budget; stitching adds a few
        assert t.max_error_m > 0.01
    assert_rays_within_error(src, ts, n_rays=500)
    both = convert_to_tiles(src, tmp_path / "both", max_error=0.2, max_triangles=100000, tile_px=64)
    assert both.meta["totals"]["max_error_m"] <= 0.2


@pytest.mark.parametrize(("kw", "words"), [({"fmt": "ply"}, "--format"), ({"tile_px": 1}, "--tile-px"),
                                           ({"max_error": -1.0}, "--max-error"), ({"max_triangles": 1}, "--max-")])
def test_bad_tile_options(tmp_path: Path, kw: dict, words: str) -> None:
    z = smooth(20, 20).astype(np.float32)
    src = write_dsm(tmp_path / "s.tif", z, transform=from_origin(0, 20, 1, 1), crs="EPSG:32633")
    with pytest.raises(InputError, match=words):
        convert_to_tiles(src, tmp_path / "o", **kw)
    assert not (tmp_path / "o").exists()


def test_load_tiles_rejects_other_dirs(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="tiles.json"):
        load_tiles(tmp_path)
