"""``vinecli terrain reconstruct`` end to end through the Typer app: real clouds, bad input, outputs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pointcloud_synth import terrain_cloud, write_las, write_ply, write_xyz
from repo_paths import shared_files
from typer.testing import CliRunner

from vinecli.cli.app import app

DATA = Path(__file__).parents[1] / "data"
BUNDLED = sorted(DATA.glob("*.laz"))
# Every cloud of ../shared/data/pointclouds when it is there, else the bundled copies.
ALL_CLOUDS = shared_files("pointclouds", "*.la[sz]") or BUNDLED


def _run(*args: str | Path) -> object:
    return CliRunner().invoke(app, ["terrain", "reconstruct", *[str(a) for a in args]])


def _one_error_line(result: object, must_contain: str) -> str:
    lines = [ln for ln in result.stderr.splitlines() if ln.strip()]  # type: ignore[attr-defined]
    assert len(lines) == 1, result.stderr  # type: ignore[attr-defined]
    assert lines[0].startswith("vinecli: error:") and must_contain in lines[0], lines[0]
    assert "Traceback" not in result.output  # type: ignore[attr-defined]
    return lines[0]


def test_ground_mesh_and_dsm_from_real_lidar(tmp_path: Path) -> None:
    import rasterio

    out = tmp_path / "topo"
    r = _run(DATA / "lidr_topography_als.laz", "--out", out, "--classes", "2", "--dsm", "2")
    assert r.exit_code == 0, r.stderr
    assert sorted(p.name for p in out.iterdir()) == ["dsm.tif", "manifest.json", "mesh.obj", "stats.json"]
    stats = json.loads((out / "stats.json").read_text())
    p = stats["points"]
    assert (p["in"], p["after_filters"], p["class_filtered_out"]) == (73_403, 8_159, 65_244)
    assert stats["crs"]["epsg"] == 2949 and stats["units"]["xy_to_m"] == 1.0
    assert stats["mesh"]["components"] == 1  # ground only: one piece (docs/terrain.md §2)
    assert stats["holes_after"] < stats["holes_before"]
    assert stats["radii_m"] == pytest.approx([2 * stats["spacing_m"]["d"], 4 * stats["spacing_m"]["d"],
                                              8 * stats["spacing_m"]["d"]])
    for stage in ("read", "voxel", "normals", "bpa", "fill_holes", "dsm", "write", "total"):
        assert stats["seconds"][stage] >= 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["command"] == "terrain reconstruct" and manifest["parameters"]["classes"] == [2]
    assert {o["path"] for o in manifest["outputs"]} == {"dsm.tif", "mesh.obj", "stats.json"}
    with rasterio.open(out / "dsm.tif") as ds:
        assert ds.crs.to_epsg() == 2949 and ds.res == (2.0, 2.0) and ds.count == 1
        z = ds.read(1)
    assert np.isfinite(z).all() and 788 < z.min() and z.max() < 830  # ground 789-815 m
    assert "holes" in r.stdout and "components" in r.stdout
    # OBJ vertices are local metres around the recorded offset.
    v = np.array([ln.split()[1:] for ln in (out / "mesh.obj").read_text().splitlines() if ln.startswith("v ")],
                 dtype=float)
    world = v + stats["offset_m"]
    assert 273_357 <= world[:, 0].min() and world[:, 0].max() <= 273_643
    assert np.abs(v).max() < 200


def test_feet_cloud_reconstructs_in_metres(tmp_path: Path) -> None:
    out = tmp_path / "autzen"
    r = _run(DATA / "autzen_trim_als_rgb_ft.laz", "--out", out, "--method", "delaunay25d", "--max-points", "20000",
             "--classes", "2")
    assert r.exit_code == 0, r.stderr
    stats = json.loads((out / "stats.json").read_text())
    assert stats["units"]["xy_unit"] == "foot" and stats["crs"]["name"].endswith("(metre)")
    assert stats["source_crs"]["epsg"] is None
    assert stats["points"]["used"] <= 20_000
    assert stats["mesh"]["holes"] == 0 and stats["mesh"]["components"] == 1
    # 1177 x 563 ft bounding box = 359 x 172 m: the ground mesh covers about that (in m², not ft²).
    assert 0.8 * 359 * 172 < stats["mesh"]["area_m2"] < 1.2 * 359 * 172


@pytest.mark.parametrize("method", ["bpa", "delaunay25d"])
@pytest.mark.parametrize("cloud", ALL_CLOUDS, ids=lambda p: p.stem)
def test_every_real_cloud_reconstructs(tmp_path: Path, cloud: Path, method: str) -> None:
    out = tmp_path / "o"
    r = _run(cloud, "--out", out, "--method", method, "--max-points", "20000")
    assert r.exit_code == 0, r.stderr
    stats = json.loads((out / "stats.json").read_text())
    m = stats["mesh"]
    assert 0 < stats["points"]["used"] <= 20_000 and m["triangles"] > stats["points"]["used"] // 2
    if method == "delaunay25d":
        assert m["holes"] == 0 and m["components"] == 1 and m["non_manifold_edges"] == 0
    else:
        assert stats["holes_after"] <= stats["holes_before"] and m["components"] >= 1
    assert stats["seconds"]["total"] < 60


def test_xyz_and_ply_inputs(tmp_path: Path) -> None:
    cloud = terrain_cloud(40, 40, noise=0.01)
    for path in (write_xyz(tmp_path / "c.xyz", cloud, delimiter=","), write_ply(tmp_path / "c.ply", cloud)):
        out = tmp_path / f"o-{path.suffix[1:]}"
        r = _run(path, "--out", out, "--voxel", "0", "--radii", "1,2,4")
        assert r.exit_code == 0, r.stderr
        stats = json.loads((out / "stats.json").read_text())
        assert stats["radii_m"] == [1.0, 2.0, 4.0] and stats["points"]["used"] == 1600
        assert stats["crs"] is None and stats["mesh"]["components"] == 1


def _bad(tmp: Path) -> dict[str, tuple[list[str | Path], str]]:
    cloud = terrain_cloud(20, 20)
    (tmp / "x.foo").write_text("1 2 3\n")
    (tmp / "text.las").write_text("not a las file\n")
    (tmp / "trunc.laz").write_bytes((DATA / "lidr_mixedconifer_forest_normalized.laz").read_bytes()[:100_000])
    good = write_xyz(tmp / "good.xyz", cloud)
    busy = tmp / "busy"
    busy.mkdir()
    (busy / "keep.txt").write_text("mine")
    return {
        "unknown extension": ([tmp / "x.foo"], "unknown point-cloud extension"),
        "text named .las": ([tmp / "text.las"], "text.las"),
        "truncated laz": ([tmp / "trunc.laz"], "trunc.laz"),
        "empty cloud": ([write_las(tmp / "empty.laz", np.empty((0, 3)))], "empty point cloud"),
        "one point": ([write_xyz(tmp / "one.xyz", cloud[:1])], "only 1 point"),
        "all NaN": ([write_xyz(tmp / "nan.xyz", np.full((4, 3), np.nan))], "NaN"),
        "collinear": ([write_xyz(tmp / "line.xyz", np.outer(np.arange(9.0), [1, 1, 1]))], "collinear"),
        "bad bbox": ([good, "--bbox", "1,2,3"], "--bbox"),
        "bad radii": ([good, "--radii", "1,x"], "--radii"),
        "bad method": ([good, "--method", "poisson"], "--method"),
        "bad voxel": ([good, "--voxel", "-2"], "--voxel"),
        "out not empty": ([good, "--out", busy], "not empty"),
    }


def test_bad_input_one_line_exit_2_nothing_written(tmp_path: Path) -> None:
    for name, (args, text) in _bad(tmp_path).items():
        out = tmp_path / f"out-{name.replace(' ', '-')}"
        if "--out" not in args:
            args = [*args, "--out", out]
        r = _run(*args)
        assert r.exit_code == 2, (name, r.stderr)
        _one_error_line(r, text)
        assert not out.exists(), name
    assert (tmp_path / "busy" / "keep.txt").read_text() == "mine"
    assert not [p for p in tmp_path.iterdir() if ".tmp-" in p.name]


def test_overwrite_replaces_output(tmp_path: Path) -> None:
    path = write_xyz(tmp_path / "c.xyz", terrain_cloud(20, 20))
    out = tmp_path / "o"
    assert _run(path, "--out", out, "--method", "delaunay25d").exit_code == 0
    r = _run(path, "--out", out, "--method", "delaunay25d", "--overwrite", "--dsm", "1")
    assert r.exit_code == 0, r.stderr
    assert (out / "dsm.tif").exists()


def test_dsm_is_accepted_by_terrain_convert(tmp_path: Path) -> None:
    out = tmp_path / "rc"
    r = _run(DATA / "autzen_trim_als_rgb_ft.laz", "--out", out, "--classes", "2", "--method", "delaunay25d",
             "--max-points", "5000", "--dsm", "1")
    assert r.exit_code == 0, r.stderr
    runner = CliRunner()
    hm = runner.invoke(app, ["terrain", "convert", str(out / "dsm.tif"), "--to", "heightmap", "--size", "129",
                             "--out", str(tmp_path / "hm")])
    assert hm.exit_code == 0, hm.stderr
    meta = json.loads((tmp_path / "hm" / "heightmap.json").read_text())
    # The feet cloud became a metre DSM: 172 m is the short side of the 359 x 172 m footprint.
    assert meta["size_m"][0] == pytest.approx(172, abs=3)
    assert 123 < meta["z_min"] < meta["z_max"] < 160
    tiles = runner.invoke(app, ["terrain", "convert", str(out / "dsm.tif"), "--to", "tiles", "--tile-px", "128",
                                "--workers", "1", "--out", str(tmp_path / "tiles")])
    assert tiles.exit_code == 0, tiles.stderr
    assert list((tmp_path / "tiles").rglob("*.obj"))


def test_terrain_info_describes_a_cloud() -> None:
    r = CliRunner().invoke(app, ["terrain", "info", str(DATA / "lidr_mixedconifer_forest_normalized.laz"), "--json"])
    assert r.exit_code == 0, r.stderr
    facts = json.loads(r.stdout)
    assert facts["kind"] == "pointcloud" and facts["points"] == 37_657 and facts["duplicate_points"] == 1
    assert facts["crs"]["epsg"] == 26912 and facts["units"]["z_source"] == "geokey"
    # Data README: 31,832 / 5,820 / 5 before removing the one duplicate (a class-1 point).
    assert {int(k): v["count"] for k, v in facts["classes"].items()} == {1: 31_831, 2: 5_820, 11: 5}
