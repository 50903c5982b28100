"""Point cloud -> mesh library: readers, units, cleaning, ball pivoting vs 2.5-D Delaunay, holes, DSM, info.

Synthetic clouds are sampled from an analytic surface (tests/pointcloud_synth.py) so the mesh
geometry can be checked against the truth; real LiDAR files come from tests/data (copies of
../shared/data/pointclouds, see tests/data/README.md).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pointcloud_synth import (
    ORIGIN,
    read_obj,
    surface_at,
    terrain_cloud,
    write_las,
    write_pcd,
    write_ply,
    write_xyz,
)

from vinecli.errors import InputError, OutputError, TerrainError
from vinecli.terrain.pointcloud.cloud_info import cloud_info
from vinecli.terrain.pointcloud.mesh import delaunay25d, fill_holes, mesh_stats
from vinecli.terrain.pointcloud.prep import unique_mask, voxel_count
from vinecli.terrain.pointcloud.readers import read_cloud
from vinecli.terrain.pointcloud.reconstruct import ReconstructOptions, parse_list, reconstruct_cloud
from vinecli.terrain.pointcloud.units import cloud_units, metric_crs, to_metres

DATA = Path(__file__).parents[2] / "data"


@pytest.fixture(scope="module")
def cloud() -> np.ndarray:
    """12,000 jittered samples of the analytic surface, 1 cm noise, UTM-sized coordinates."""
    return terrain_cloud(noise=0.01)


def _mesh_world(out: Path) -> tuple[np.ndarray, np.ndarray, dict]:
    stats = json.loads((out / "stats.json").read_text())
    v, f = read_obj(out / "mesh.obj")
    return v + np.asarray(stats["offset_m"]), f, stats


# --------------------------------------------------------------------------- readers


@pytest.mark.parametrize("kind", ["las", "laz", "ply-bin", "ply-ascii", "pcd-ascii", "pcd-binary",
                                  "pcd-compressed", "xyz-space", "xyz-comma", "csv-header"])
def test_readers_return_the_written_points(tmp_path: Path, cloud: np.ndarray, kind: str) -> None:
    pts = cloud[:500]
    writers = {
        "las": lambda p: write_las(p.with_suffix(".las"), pts),
        "laz": lambda p: write_las(p.with_suffix(".laz"), pts),
        "ply-bin": lambda p: write_ply(p.with_suffix(".ply"), pts),
        "ply-ascii": lambda p: write_ply(p.with_suffix(".ply"), pts, binary=False),
        "pcd-ascii": lambda p: write_pcd(p.with_suffix(".pcd"), pts),
        "pcd-binary": lambda p: write_pcd(p.with_suffix(".pcd"), pts, data="binary"),
        "pcd-compressed": lambda p: write_pcd(p.with_suffix(".pcd"), pts - ORIGIN, data="binary_compressed"),
        "xyz-space": lambda p: write_xyz(p.with_suffix(".xyz"), pts),
        "xyz-comma": lambda p: write_xyz(p.with_suffix(".xyz"), pts, delimiter=","),
        "csv-header": lambda p: write_xyz(p.with_suffix(".csv"), pts, delimiter=",", header=True),
    }
    path = writers[kind](tmp_path / "c")
    raw = read_cloud(path)
    assert raw.xyz.shape == (500, 3)
    expected = pts - ORIGIN if kind == "pcd-compressed" else pts
    # LAS stores 1 mm integers; Open3D's compressed PCD stores float32; the rest are exact doubles.
    tol = {"las": 0.0005, "laz": 0.0005, "pcd-compressed": 1e-5}.get(kind, 0.0)
    assert np.max(np.abs(raw.xyz - expected)) <= tol


def test_ply_and_las_classification_is_read(tmp_path: Path, cloud: np.ndarray) -> None:
    cls = np.where(np.arange(len(cloud)) % 3 == 0, 2, 1).astype(np.uint8)
    for path in (write_ply(tmp_path / "c.ply", cloud, classification=cls),
                 write_las(tmp_path / "c.las", cloud, classification=cls)):
        raw = read_cloud(path)
        assert raw.classification is not None and np.array_equal(raw.classification, cls)


def test_real_las_headers_and_crs() -> None:
    raw = read_cloud(DATA / "lidr_topography_als.laz")
    assert len(raw.xyz) == 73_403 and raw.crs.to_epsg() == 2949
    assert raw.header["scales"] == [0.00025, 0.00025, 0.00025]
    assert np.bincount(raw.classification).tolist()[1:3] == [61_347, 8_159]


# --------------------------------------------------------------------------- units


def test_feet_crs_without_epsg_converts_to_metres_exactly() -> None:
    raw = read_cloud(DATA / "autzen_trim_als_rgb_ft.laz")
    units = cloud_units(raw)
    assert raw.crs.to_epsg() is None
    assert (units.xy_unit, units.xy_to_m, units.z_to_m, units.z_source) == ("foot", 0.3048, 0.3048,
                                                                             "assumed-horizontal")
    m, crs_m = to_metres(raw.xyz, raw.crs, units)
    assert all(a.unit_name == "metre" for a in crs_m.axis_info)
    # Same places on Earth: the metre coordinates in the metric CRS equal the feet in the source CRS.
    from pyproj import Transformer

    lon_ft, lat_ft = Transformer.from_crs(raw.crs, 4326, always_xy=True).transform(raw.xyz[:50, 0], raw.xyz[:50, 1])
    lon_m, lat_m = Transformer.from_crs(crs_m, 4326, always_xy=True).transform(m[:50, 0], m[:50, 1])
    assert np.max(np.abs(lon_ft - lon_m)) < 1e-9 and np.max(np.abs(lat_ft - lat_m)) < 1e-9
    assert 44.0 < np.mean(lat_m) < 44.1 and -123.1 < np.mean(lon_m) < -123.0  # Eugene, Oregon
    extent = m.max(axis=0) - m.min(axis=0)
    assert extent[0] == pytest.approx(1177.46 * 0.3048, abs=0.01) and extent[2] == pytest.approx(114.25 * 0.3048,
                                                                                                abs=0.01)


def test_compound_crs_with_us_feet_height(tmp_path: Path, cloud: np.ndarray) -> None:
    from pyproj import CRS

    crs = CRS("EPSG:2994+6360")  # Oregon GIC Lambert (ft) + NAVD88 height (ftUS)
    raw = read_cloud(write_las(tmp_path / "c.las", cloud[:100] / 0.3048, crs=crs, point_format=6))
    units = cloud_units(raw)
    assert units.xy_to_m == 0.3048 and units.z_to_m == pytest.approx(1200 / 3937) and units.z_source == "crs"
    assert [a.unit_name for a in metric_crs(raw.crs).axis_info] == ["metre", "metre", "metre"]


def test_geographic_cloud_is_reprojected_to_utm(tmp_path: Path) -> None:
    from pyproj import CRS

    rng = np.random.default_rng(3)
    lonlat = np.column_stack((8.03 + rng.uniform(0, 0.001, 300), 44.70 + rng.uniform(0, 0.001, 300),
                              rng.uniform(200, 201, 300)))
    raw = read_cloud(write_las(tmp_path / "geo.las", lonlat, crs=CRS("EPSG:4326"), scale=1e-7))
    units = cloud_units(raw)
    m, crs_m = to_metres(raw.xyz, raw.crs, units)
    assert units.geographic and crs_m.to_epsg() == 32632  # WGS 84 / UTM 32N at 8° E
    extent = m.max(axis=0) - m.min(axis=0)
    # 0.001° of longitude at 44.7° N is ~79 m, of latitude ~111 m.
    assert 70 < extent[0] < 80 and 100 < extent[1] < 112


# --------------------------------------------------------------------------- geometry vs the analytic surface


@pytest.mark.parametrize("method", ["bpa", "delaunay25d"])
def test_mesh_matches_the_analytic_surface(tmp_path: Path, cloud: np.ndarray, method: str) -> None:
    out = tmp_path / "out"
    stats = reconstruct_cloud(write_ply(tmp_path / "c.ply", cloud), out,
                              ReconstructOptions(method=method, max_edge=2.0 if method == "delaunay25d" else None))
    world, faces, on_disk = _mesh_world(out)
    assert on_disk["mesh"]["triangles"] == len(faces) == stats["mesh"]["triangles"]
    assert np.allclose(stats["offset_m"], np.round(cloud.mean(axis=0)))
    # Vertices are voxel means of noisy (sigma 1 cm) samples: on the surface within noise.
    err_v = world[:, 2] - surface_at(world)
    assert np.sqrt(np.mean(err_v**2)) < 0.015 and np.max(np.abs(err_v)) < 0.06
    # Triangle centroids: chord error of ~0.6 m triangles on hills of curvature <= 0.033 1/m.
    centroids = world[faces].mean(axis=1)
    err_c = centroids[:, 2] - surface_at(centroids)
    assert np.sqrt(np.mean(err_c**2)) < 0.01 and np.max(np.abs(err_c)) < 0.05
    m = stats["mesh"]
    assert m["components"] == 1 and m["holes"] == 0 and m["downward_triangles"] == 0
    assert m["area_m2"] == pytest.approx(3000, rel=0.05)  # 60 m x 50 m, slopes add ~1%
    assert stats["radii_m"] == (None if method == "delaunay25d" else
                                pytest.approx([2 * stats["spacing_m"]["d"], 4 * stats["spacing_m"]["d"],
                                               8 * stats["spacing_m"]["d"]]))


def test_delaunay_hull_slivers_and_max_edge(tmp_path: Path, cloud: np.ndarray) -> None:
    path = write_xyz(tmp_path / "c.xyz", cloud)
    full = reconstruct_cloud(path, tmp_path / "full", ReconstructOptions(method="delaunay25d"))
    peeled = reconstruct_cloud(path, tmp_path / "peeled", ReconstructOptions(method="delaunay25d", max_edge=2.0))
    world, faces, _ = _mesh_world(tmp_path / "full")
    c = world[faces].mean(axis=1)
    assert np.max(np.abs(c[:, 2] - surface_at(c))) > 0.2  # long hull slivers cut across the hills
    assert peeled["mesh"]["triangles"] < full["mesh"]["triangles"]
    for s in (full, peeled):
        assert s["mesh"]["holes"] == 0 and s["mesh"]["components"] == 1 and s["mesh"]["boundary_loops"] == 1


def test_bpa_holes_filled_delaunay_hole_free(tmp_path: Path, cloud: np.ndarray) -> None:
    local = cloud - ORIGIN
    gaps = [(15.0, 15.0), (40.0, 30.0)]
    keep = np.ones(len(cloud), dtype=bool)
    for gx, gy in gaps:
        keep &= np.hypot(local[:, 0] - gx, local[:, 1] - gy) > 5.0  # wider than the largest ball (8d)
    path = write_las(tmp_path / "gaps.laz", cloud[keep])
    bpa = reconstruct_cloud(path, tmp_path / "bpa", ReconstructOptions())
    dl = reconstruct_cloud(path, tmp_path / "dl", ReconstructOptions(method="delaunay25d"))
    assert bpa["holes_before"] >= 2 and bpa["holes_after"] == 0
    assert bpa["hole_patches_filled"] == bpa["holes_before"]
    assert bpa["mesh"]["components"] == 1 and bpa["mesh"]["downward_triangles"] == 0
    # The patches cover the two 5 m gaps: about 2 * pi * 5^2 = 157 m² of extra area.
    before = bpa["mesh_before_fill"]["area_m2"]
    assert before == pytest.approx(3000 - 157, rel=0.02)
    assert 140 < bpa["mesh"]["area_m2"] - before < 180
    assert dl["mesh"]["holes"] == 0 and dl["mesh"]["components"] == 1
    assert bpa["seconds"]["bpa"] > 0 and dl["seconds"]["delaunay"] > 0


# --------------------------------------------------------------------------- feet -> metres end to end


def test_cloud_in_feet_gives_the_same_mesh_in_metres(tmp_path: Path, cloud: np.ndarray) -> None:
    from pyproj import CRS

    # Same integer grid in both files (offset 0; 0.01 ft = 3.048 mm steps); no CRS = metres.
    ft = write_las(tmp_path / "ft.las", cloud / 0.3048, crs=CRS("EPSG:2994"), scale=0.01, offsets=(0, 0, 0))
    m = write_las(tmp_path / "m.las", cloud, scale=0.01 * 0.3048, offsets=(0, 0, 0))
    for method in ("delaunay25d", "bpa"):
        opts = ReconstructOptions(method=method, voxel=0.8, max_edge=2.0)
        s_ft = reconstruct_cloud(ft, tmp_path / f"ft-{method}", opts)
        s_m = reconstruct_cloud(m, tmp_path / f"m-{method}", opts)
        assert s_ft["units"]["xy_to_m"] == 0.3048 and s_m["units"]["xy_to_m"] == 1.0
        assert s_ft["offset_m"] == s_m["offset_m"]
        v_ft, f_ft, _ = _mesh_world(tmp_path / f"ft-{method}")
        v_m, f_m, _ = _mesh_world(tmp_path / f"m-{method}")
        assert len(f_ft) == len(f_m) and len(v_ft) == len(v_m)
        assert np.max(np.abs(v_ft - v_m)) < 2e-4  # OBJ keeps 0.1 mm
        assert s_ft["mesh"]["area_m2"] == pytest.approx(s_m["mesh"]["area_m2"], rel=1e-6)
        assert s_ft["mesh"]["area_m2"] == pytest.approx(3000, rel=0.05)  # metres, not feet (x 10.76)


# --------------------------------------------------------------------------- counts: NaN, duplicates, filters


def test_nan_duplicate_class_and_bbox_counts(tmp_path: Path, cloud: np.ndarray) -> None:
    rng = np.random.default_rng(7)
    n = len(cloud)
    cls = rng.choice(np.array([1, 2, 9], dtype=np.uint8), n, p=[0.3, 0.6, 0.1])
    dup_idx = rng.choice(n, 37, replace=False)
    pts = np.vstack([cloud, cloud[dup_idx]])
    cls = np.concatenate([cls, cls[dup_idx]])
    nan_rows = rng.choice(len(pts), 11, replace=False)
    pts[nan_rows[:6], 2] = np.nan
    pts[nan_rows[6:], 0] = np.inf
    path = write_ply(tmp_path / "c.ply", pts, classification=cls)
    ok = np.all(np.isfinite(pts), axis=1)
    n_dup = int(ok.sum() - unique_mask(pts[ok]).sum())
    cls_ok = cls[ok][unique_mask(pts[ok])]
    stats = reconstruct_cloud(path, tmp_path / "g", ReconstructOptions(classes=(2,), method="delaunay25d"))
    p = stats["points"]
    assert p["in"] == n + 37 and p["nan_dropped"] == 11 and p["after_nan"] == n + 26
    assert p["duplicates_removed"] == n_dup and 30 <= n_dup <= 37  # a NaN may hit a duplicate
    assert p["after_filters"] == int(np.sum(cls_ok == 2))
    assert p["class_filtered_out"] == int(np.sum(cls_ok != 2))
    two = reconstruct_cloud(path, tmp_path / "g9", ReconstructOptions(classes=(2, 9), method="delaunay25d"))
    assert two["points"]["after_filters"] == int(np.sum(np.isin(cls_ok, [2, 9])))

    x0, y0 = ORIGIN[0] + 10, ORIGIN[1] + 5
    bbox = (x0, y0, x0 + 20, y0 + 15)
    box = reconstruct_cloud(path, tmp_path / "box", ReconstructOptions(bbox=bbox, method="delaunay25d"))
    clean = pts[ok][unique_mask(pts[ok])]
    inside = (clean[:, 0] >= bbox[0]) & (clean[:, 0] <= bbox[2]) & (clean[:, 1] >= bbox[1]) & (clean[:, 1] <= bbox[3])
    assert box["points"]["after_filters"] == int(inside.sum())
    assert box["points"]["bbox_filtered_out"] == int((~inside).sum())


def test_real_duplicates_are_counted() -> None:
    assert cloud_info(DATA / "lidr_mixedconifer_forest_normalized.laz")["duplicate_points"] == 1
    assert cloud_info(DATA / "lidr_topography_als.laz")["duplicate_points"] == 0


def test_max_points_enlarges_the_voxel(tmp_path: Path, cloud: np.ndarray) -> None:
    path = write_xyz(tmp_path / "c.txt", cloud)
    s = reconstruct_cloud(path, tmp_path / "o", ReconstructOptions(max_points=2000, method="delaunay25d"))
    assert s["points"]["used"] <= 2000 and s["points"]["used"] > 1000
    assert "enlarged" in s["voxel_source"] and s["voxel_m"] > 1.0


# --------------------------------------------------------------------------- mesh topology units


def _grid(n: int = 10) -> tuple[np.ndarray, np.ndarray]:
    g = np.stack(np.meshgrid(np.arange(float(n)), np.arange(float(n))), -1).reshape(-1, 2)
    v = np.column_stack((g, 0.1 * g[:, 0]))
    return delaunay25d(v)


def test_mesh_stats_counts_loops_holes_components_nonmanifold() -> None:
    v, f = _grid()
    s = mesh_stats(v, f)
    assert (s["triangles"], s["boundary_loops"], s["holes"], s["components"]) == (162, 1, 0, 1)
    assert s["area_m2"] == pytest.approx(81 * np.sqrt(1.01))
    c = v[f].mean(axis=1)
    holed = f[~((np.abs(c[:, 0] - 4.5) < 1.5) & (np.abs(c[:, 1] - 4.5) < 1.5))]
    s = mesh_stats(v, holed)
    assert (s["boundary_loops"], s["holes"], s["components"], s["unused_points"]) == (2, 1, 1, 4)
    # A second piece, and a fin: a third triangle on an existing edge (non-manifold).
    v2 = np.vstack([v, [[20, 20, 0], [21, 20, 0], [20, 21, 0], [0.5, 0.5, 3.0]]])
    e = f[0]
    f2 = np.vstack([f, [[100, 101, 102], [e[0], e[1], 103]]])
    s = mesh_stats(v2, f2)
    assert s["components"] == 2 and s["non_manifold_edges"] == 1


def test_fill_holes_fills_holes_only_and_keeps_orientation() -> None:
    v, f = _grid()
    c = v[f].mean(axis=1)
    hole = ((np.abs(c[:, 0] - 4.5) < 1.5) & (np.abs(c[:, 1] - 4.5) < 1.5)) | (
        (np.abs(c[:, 0] - 1.5) < 0.6) & (np.abs(c[:, 1] - 7.5) < 0.6))
    v2 = np.vstack([v, [[20, 20, 0], [21, 20, 0], [20, 21, 0]]])  # a lone triangle: VTK would cap it
    f2 = np.vstack([f[~hole], [[100, 101, 102]]])
    before = mesh_stats(v2, f2)
    filled, patches = fill_holes(v2, f2)
    after = mesh_stats(v2, filled)
    assert before["holes"] == 2 and after["holes"] == 0 and patches == 2
    # Outer boundaries are not capped: the area is the plane's again (the 3x3 hole is flat-filled
    # over its 4 interior points) plus the lone triangle, and no triangle faces down.
    assert after["area_m2"] == pytest.approx(81 * np.sqrt(1.01) + 0.5, rel=1e-9)
    assert after["downward_triangles"] == 0 and after["components"] == 2 and after["boundary_loops"] == 2


def test_voxel_count_matches_open3d(cloud: np.ndarray) -> None:
    from vinecli.terrain.pointcloud.mesh import voxel_resample

    local = cloud - cloud.mean(axis=0)
    for voxel in (0.3, 0.77, 2.0):
        assert voxel_count(local, voxel) == len(voxel_resample(local, voxel))


# --------------------------------------------------------------------------- DSM


def test_dsm_takes_the_max_per_cell_and_reports_filling(tmp_path: Path) -> None:
    import rasterio
    from pyproj import CRS

    # 4 x 3 cells of 1 m over [100, 104) x (200, 203]: two points in cell (0, 0), one cell per other
    # populated cell, and two empty cells.
    pts = np.array([[100.2, 202.5, 5.0], [100.7, 202.2, 7.5],  # row 0, col 0: max 7.5
                    [101.5, 202.5, 6.0], [102.5, 202.5, 6.5], [103.5, 202.5, 9.0],
                    [100.5, 201.5, 4.0], [103.5, 201.5, 8.0],  # row 1: cols 1, 2 empty
                    [100.5, 200.5, 3.0], [101.5, 200.5, 3.5], [102.5, 200.5, 2.0], [103.5, 200.5, 1.0]])
    crs = CRS("EPSG:32632")
    path = write_las(tmp_path / "d.las", pts, crs=crs)
    s = reconstruct_cloud(path, tmp_path / "o", ReconstructOptions(dsm_res=1.0, method="delaunay25d", voxel=0))
    with rasterio.open(tmp_path / "o" / "dsm.tif") as ds:
        z = ds.read(1)
        assert ds.crs.to_epsg() == 32632 and ds.res == (1.0, 1.0) and ds.dtypes[0] == "float32"
        assert tuple(ds.bounds) == (100.0, 200.0, 104.0, 203.0)
    assert z.shape == (3, 4)
    assert z[0].tolist() == [7.5, 6.0, 6.5, 9.0] and z[2].tolist() == [3.0, 3.5, 2.0, 1.0]
    assert z[1, 0] == 4.0 and z[1, 3] == 8.0
    assert z[1, 1] in (4.0, 6.0, 3.5) and z[1, 2] in (8.0, 6.5, 2.0)  # nearest filled neighbour
    assert s["dsm"]["filled_fraction"] == pytest.approx(2 / 12)


def test_dsm_from_feet_cloud_is_in_metres(tmp_path: Path) -> None:
    import rasterio

    s = reconstruct_cloud(DATA / "autzen_trim_als_rgb_ft.laz", tmp_path / "o",
                          ReconstructOptions(method="delaunay25d", classes=(2,), dsm_res=2.0, max_points=5000))
    with rasterio.open(tmp_path / "o" / "dsm.tif") as ds:
        z = ds.read(1)
        assert ds.crs.linear_units in ("metre", "meter") and ds.res == (2.0, 2.0)
        assert ds.width == pytest.approx(359 / 2, abs=2) and ds.height == pytest.approx(172 / 2, abs=2)
    assert 120 < z.min() and z.max() < 160  # 406-520 ft = 124-159 m
    assert 0 < s["dsm"]["filled_fraction"] < 1


# --------------------------------------------------------------------------- info


def test_cloud_info_reports_what_reconstruct_would_do(tmp_path: Path) -> None:
    info = cloud_info(DATA / "autzen_trim_als_rgb_ft.laz")
    assert info["points"] == 110_000 and info["crs"]["epsg"] is None
    assert info["units"]["xy_unit"] == "foot" and info["metric_crs"].endswith("(metre)")
    assert info["classes"] == {1: {"name": "unclassified", "count": 83_893}, 2: {"name": "ground", "count": 26_107}}
    assert info["extent_m"][0] == pytest.approx(358.89, abs=0.01)
    assert info["density_per_m2"] == pytest.approx(1.79, abs=0.02)  # data README: ~1.8 pts/m²
    assert any("--classes 2" in n for n in info["notes"]) and any("foot" in n for n in info["notes"])
    s = reconstruct_cloud(DATA / "autzen_trim_als_rgb_ft.laz", tmp_path / "o",
                          ReconstructOptions(method="delaunay25d"))
    assert s["points"]["used"] == info["reconstruct"]["points_after_voxel"]
    assert s["voxel_m"] == pytest.approx(info["reconstruct"]["voxel_m"], abs=1e-4)


# --------------------------------------------------------------------------- bad input


def _bad_files(tmp: Path, cloud: np.ndarray) -> dict[str, tuple[Path, type, str]]:
    good_ply = write_ply(tmp / "good.ply", cloud[:200])
    trunc_ply = tmp / "trunc.ply"
    trunc_ply.write_bytes(good_ply.read_bytes()[:-100])
    good_ascii = write_ply(tmp / "good_ascii.ply", cloud[:200], binary=False)
    trunc_ascii = tmp / "trunc_ascii.ply"
    trunc_ascii.write_bytes(good_ascii.read_bytes()[:-200])
    trunc_laz = tmp / "trunc.laz"
    trunc_laz.write_bytes((DATA / "lidr_topography_als.laz").read_bytes()[:200_000])
    full_las = write_las(tmp / "full.las", cloud[:300])
    trunc_las = tmp / "trunc.las"
    trunc_las.write_bytes(full_las.read_bytes()[:-500])
    text_las = tmp / "text.las"
    text_las.write_text("this is not a LAS file\n")
    trunc_pcd = tmp / "trunc.pcd"
    trunc_pcd.write_bytes(write_pcd(tmp / "g.pcd", cloud[:200], data="binary").read_bytes()[:-8])
    empty_las = write_las(tmp / "empty.las", np.empty((0, 3)))
    (tmp / "x.foo").write_text("1 2 3\n")
    return {
        "unknown extension": (tmp / "x.foo", InputError, "unknown point-cloud extension"),
        "missing": (tmp / "nope.laz", InputError, "not found"),
        "text named .las": (text_las, TerrainError, "cannot read LAS/LAZ"),
        "truncated laz": (trunc_laz, TerrainError, "cannot read LAS/LAZ"),
        "truncated las": (trunc_las, TerrainError, "cannot read LAS/LAZ"),
        "truncated ply": (trunc_ply, TerrainError, "truncated"),
        "truncated ascii ply": (trunc_ascii, TerrainError, "truncated"),
        "truncated pcd": (trunc_pcd, TerrainError, "truncated"),
        "empty las": (empty_las, TerrainError, "empty point cloud"),
        "empty xyz": (write_xyz(tmp / "e.xyz", np.empty((0, 3))), TerrainError, "empty point cloud"),
        "one point": (write_xyz(tmp / "one.xyz", cloud[:1]), TerrainError, "only 1 point"),
        "two points": (write_xyz(tmp / "two.xyz", cloud[:2]), TerrainError, "only 2 points"),
        "collinear": (write_xyz(tmp / "line.xyz", np.outer(np.arange(50.0), [1.0, 2.0, 0.5])), TerrainError,
                      "collinear"),
        "all nan": (write_xyz(tmp / "nan.xyz", np.full((5, 3), np.nan)), TerrainError, "NaN/inf"),
        "classes without classification": (write_xyz(tmp / "nocls.xyz", cloud[:100]), InputError, "classification"),
        "filter leaves nothing": (write_las(tmp / "c9.las", cloud[:100], classification=np.full(100, 9)),
                                  TerrainError, "no points left"),
    }


def test_bad_inputs_raise_one_clear_error_and_leave_nothing(tmp_path: Path, cloud: np.ndarray) -> None:
    cases = _bad_files(tmp_path, cloud)
    for name, (path, exc, text) in cases.items():
        out = tmp_path / f"out-{path.stem}"
        opts = ReconstructOptions(classes=(2,) if name in ("classes without classification",
                                                         "filter leaves nothing") else None)
        with pytest.raises(exc) as info:
            reconstruct_cloud(path, out, opts)
        assert text in str(info.value), name
        assert info.value.path == str(path), name
        assert "\n" not in str(info.value)
        assert not out.exists(), name
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out-")]


def test_vertical_wall_is_refused_by_delaunay25d(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    t = rng.uniform(0, 10, 200)
    pts = np.column_stack((t, 2.0 * t, rng.uniform(0, 5, 200)))  # a vertical plane: a line in plan view
    path = write_xyz(tmp_path / "wall.xyz", pts)
    with pytest.raises(TerrainError, match="collinear"):
        reconstruct_cloud(path, tmp_path / "o", ReconstructOptions(method="delaunay25d", voxel=0))
    assert not (tmp_path / "o").exists()


def test_option_validation(tmp_path: Path) -> None:
    path = write_xyz(tmp_path / "c.xyz", terrain_cloud(20, 20))
    for opts in (ReconstructOptions(method="poisson"), ReconstructOptions(voxel=-1),  # type: ignore[arg-type]
                 ReconstructOptions(radii=(0.5, -1)), ReconstructOptions(bbox=(5, 0, 1, 1)),
                 ReconstructOptions(max_points=2), ReconstructOptions(dsm_res=0)):
        with pytest.raises(InputError):
            reconstruct_cloud(path, tmp_path / "o", opts)
    with pytest.raises(InputError, match="--radii"):
        parse_list("1,a", "--radii")
    assert parse_list("2, 9", "--classes", int) == (2, 9)
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "keep.txt").write_text("x")
    with pytest.raises(OutputError):
        reconstruct_cloud(path, tmp_path / "busy", ReconstructOptions())
    assert (tmp_path / "busy" / "keep.txt").read_text() == "x"


def test_mesh_obj_loads_in_pybullet_and_rays_hit_the_surface(tmp_path: Path, cloud: np.ndarray) -> None:
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    stats = reconstruct_cloud(write_ply(tmp_path / "c.ply", cloud), tmp_path / "o",
                              ReconstructOptions(method="bpa"))
    client = BulletClient(connection_mode=pybullet.DIRECT)
    try:
        shape = client.createCollisionShape(pybullet.GEOM_MESH, fileName=str(tmp_path / "o" / "mesh.obj"),
                                            flags=pybullet.GEOM_FORCE_CONCAVE_TRIMESH)
        client.createMultiBody(baseMass=0, baseCollisionShapeIndex=shape)
        rng = np.random.default_rng(11)
        local_xy = rng.uniform([3, 3], [57, 47], (200, 2))
        off = np.asarray(stats["offset_m"])
        xy = local_xy + (ORIGIN[0], ORIGIN[1]) - off[:2]
        hits = client.rayTestBatch([(x, y, 50.0) for x, y in xy], [(x, y, -50.0) for x, y in xy])
    finally:
        client.disconnect()
    z_hit = np.array([h[3][2] for h in hits]) + off[2]
    assert all(h[0] >= 0 for h in hits)
    world = np.column_stack((xy + off[:2], np.zeros(len(xy))))
    assert np.max(np.abs(z_hit - surface_at(world))) < 0.06
