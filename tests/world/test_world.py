"""world build: world.json, terrain, URDF and a Gazebo SDF that parses and references existing files."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import rasterio
from lxml import etree
from sim_helpers import world_yaml
from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.errors import SpecError
from vinecli.world import build_world, load_world
from vinecli.world.sdf import sdf_uris


def _check_sdf(d):
    sdf = d / "world.sdf"
    root = etree.parse(str(sdf)).getroot()
    assert root.tag == "sdf" and root.get("version") == "1.9"
    world = root.find("world")
    sc = world.find("spherical_coordinates")
    assert sc.findtext("surface_model") == "EARTH_WGS84" and sc.findtext("world_frame_orientation") == "ENU"
    wj = json.loads((d / "world.json").read_text())
    assert float(sc.findtext("latitude_deg")) == pytest.approx(wj["origin"]["lat"], abs=1e-8)
    assert float(sc.findtext("longitude_deg")) == pytest.approx(wj["origin"]["lon"], abs=1e-8)
    assert world.find("wind/linear_velocity") is not None
    for uri in sdf_uris(sdf):
        assert (d / uri).is_file(), uri
    plugins = world.findall("model/plugin[@filename='gz-sim-multicopter-motor-model-system']")
    assert len(plugins) == len(wj["vehicle"]["spec"]["rotors"])
    assert {p.findtext("turningDirection") for p in plugins} == {"cw", "ccw"}
    return world


def test_flat_world(flat_world_dir):
    w = load_world(flat_world_dir)
    assert w.terrain.kind == "flat" and w.origin.lat == pytest.approx(47.397742)
    assert w.spawn_enu[2] == pytest.approx(w.vehicle.frame.landing_gear_height_m, abs=0.005)
    assert w.terrain_height(12.0, -40.0) == 0.0
    assert (flat_world_dir / "manifest.json").is_file()
    world = _check_sdf(flat_world_dir)
    assert world.find("model[@name='terrain']/link/collision/geometry/plane") is not None


def test_dsm_tiles_world(bumpy_worlds, bumpy_dsm):
    d = bumpy_worlds["tiles"]
    w = load_world(d)
    assert w.terrain.kind == "tiles" and len([f for f in w.terrain.files if f.suffix == ".obj"]) == 16
    # origin: raster centre (UTM 32N 465012.05, 5249987.95) at the height there
    with rasterio.open(bumpy_dsm) as ds:
        z = ds.read(1, masked=True)
    assert w.origin.alt == pytest.approx(float(z[120, 120]), abs=1e-3)
    assert 47.0 < w.origin.lat < 47.5 and 8.5 < w.origin.lon < 8.6
    assert w.terrain_height(0.0, 0.0) == pytest.approx(0.0, abs=0.02)
    # grid heights (ray-cast on the tiles) = DSM heights - origin alt within the 2 cm max error;
    # 241 px of 0.1 m: the north-west pixel centre is at (-12, 12)
    assert w.terrain_height(-12.0, 12.0) == pytest.approx(float(z[0, 0]) - w.origin.alt, abs=0.021)
    assert w.terrain_height(12.0, -12.0) == pytest.approx(float(z[-1, -1]) - w.origin.alt, abs=0.021)
    assert w.terrain_height(-12.0 + 0.7, 12.0 - 0.5) == pytest.approx(float(z[5, 8]) - w.origin.alt, abs=0.07)
    # spawn on the surface
    assert w.spawn_enu[2] >= w.terrain_height(1.0, -2.0) + w.vehicle.frame.landing_gear_height_m
    world = _check_sdf(d)
    assert len(world.findall("model[@name='terrain']/link/collision/geometry/mesh")) == 16
    # the lookup grid agrees with the collision surface (PyBullet rays) and with the DSM
    from vinecli.world.engine import Engine

    with Engine() as e:
        e.load_terrain(w.terrain)
        rng = np.random.default_rng(0)
        for x, y in rng.uniform(-11, 11, (50, 2)):
            assert abs(e.ray_height(x, y) - w.terrain_height(x, y)) < 0.02
            col, row = int(round((x + 12.0) / 0.1)), int(round((12.0 - y) / 0.1))
            if (row, col) != (5, 7):
                assert abs(w.terrain_height(x, y) - (float(z[row, col]) - w.origin.alt)) < 0.02 + 0.06


def test_dsm_heightmap_world(bumpy_worlds):
    d = bumpy_worlds["heightmap"]
    w = load_world(d)
    assert w.terrain.kind == "heightmap"
    g = w.terrain.grid
    assert g.nx == g.ny == 129
    with rasterio.open(d / "terrain" / "heightmap.png") as ds:
        png = ds.read(1)
        assert ds.dtypes[0] == "uint16" and ds.width == 129
    zmin, zmax = g.z_range
    assert np.allclose(zmin + png[::-1].astype(float) / 65535 * (zmax - zmin), g.z, atol=(zmax - zmin) / 65535)
    world = _check_sdf(d)
    hm = world.find("model[@name='terrain']/link/collision/geometry/heightmap")
    size = [float(s) for s in hm.findtext("size").split()]
    pos = [float(s) for s in hm.findtext("pos").split()]
    assert size[2] == pytest.approx(zmax - zmin) and pos[2] == pytest.approx(zmin)
    assert size[0] == pytest.approx(24.0, abs=1e-6)  # 240 pixel spacings of 0.1 m


def test_vineyard_sample_builds_from_the_repo(sample_world_dir):
    d = sample_world_dir  # build_world of worlds/vineyard-sample.yaml, built once per session (tests/conftest.py)
    w = load_world(d)
    assert w.terrain.kind == "tiles"
    xmin, ymin, xmax, ymax = w.terrain.bounds
    assert xmax - xmin == pytest.approx(19.0, abs=0.1) and ymax - ymin == pytest.approx(68.6, abs=0.1)
    assert abs(w.origin.lat - 44.119) < 0.01 and abs(w.origin.lon + 89.542) < 0.01
    assert len(w.vine_rows_enu) == 16
    for row in w.vine_rows_enu:
        for x, y in row:
            assert xmin < x < xmax and ymin < y < ymax
    # the rows follow the canopy: terrain along a row is higher than midway between rows
    on, off = [], []
    for row in w.vine_rows_enu[1:-1]:
        (x0, y0), (x1, y1) = row[0], row[-1]
        for s in np.linspace(0.05, 0.95, 200):
            x, y = x0 + s * (x1 - x0), y0 + s * (y1 - y0)
            on.append(max(w.terrain_height(x + dx, y) for dx in (-0.1, 0.0, 0.1)))
            off.append(w.terrain_height(x + 0.46, y))
    assert np.mean(on) > np.mean(off) + 0.03
    assert w.geofence is not None and len(w.geofence.polygon_enu) == 4
    _check_sdf(d)
    assert w.spawn_enu[2] > w.terrain_height(w.spawn_enu[0], w.spawn_enu[1])


def test_spec_errors(tmp_path):
    p = world_yaml(tmp_path, {"type": "flat"})  # flat needs an origin
    with pytest.raises(SpecError, match="origin"):
        build_world(p, tmp_path / "out")
    assert not (tmp_path / "out").exists()
    p = world_yaml(tmp_path, {"type": "flat"}, origin={"lat": 1, "lon": 2}, spawn={"x_m": 500.0})
    with pytest.raises(SpecError, match="outside"):
        build_world(p, tmp_path / "out")
    p = world_yaml(tmp_path, {"type": "flat"}, origin={"lat": 1, "lon": 2}, vehicle="nope")
    with pytest.raises(SpecError, match="unknown vehicle"):
        build_world(p, tmp_path / "out")
    with pytest.raises(SpecError, match="world.json"):
        load_world(tmp_path)


def test_cli_world_build(repo, tmp_path):
    runner = CliRunner()
    out = tmp_path / "flat"
    res = runner.invoke(app, ["world", "build", str(repo / "worlds" / "flat.yaml"), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert (out / "world.json").is_file() and (out / "vehicles" / "x500-sprayer.urdf").is_file()
    res = runner.invoke(app, ["world", "build", str(repo / "worlds" / "flat.yaml"), "--out", str(out)])
    assert res.exit_code == 2 and "--overwrite" in res.output
    res = runner.invoke(app, ["world", "build", str(repo / "worlds" / "flat.yaml"), "--out", str(out), "--overwrite"])
    assert res.exit_code == 0
    bad = world_yaml(tmp_path, {"type": "dsm", "path": "missing.tif"})
    res = runner.invoke(app, ["world", "build", str(bad), "--out", str(tmp_path / "x")])
    assert res.exit_code == 2 and "missing.tif" in res.output
    assert math.isfinite(json.loads((out / "world.json").read_text())["spawn"]["yaw_rad"])


@pytest.mark.parametrize("fmt", ["tiles", "heightmap"])
def test_world_from_a_converted_terrain_dir_with_an_explicit_origin(tmp_path, bumpy_dsm, fmt):
    """`terrain convert` output as the world's terrain; an explicit origin 10 m east / 5 m north and 2 m
    below the terrain's own origin shifts the terrain by (-10, -5, +2) in the world frame."""
    from vinecli.terrain.heightmap import convert_to_heightmap
    from vinecli.terrain.tiles import convert_to_tiles

    tdir = tmp_path / "terrain"
    if fmt == "tiles":
        own = convert_to_tiles(bumpy_dsm, tdir, max_error=0.02, tile_px=64, workers=1).origin
    else:
        own = convert_to_heightmap(bumpy_dsm, tdir, size=129).origin
    m_lat, m_lon = own.metres_per_degree
    given = {"lat": own.lat + 5.0 / m_lat, "lon": own.lon + 10.0 / m_lon, "alt": own.alt - 2.0}
    ref = load_world(build_world(world_yaml(tmp_path, {"type": fmt, "dir": str(tdir)}), tmp_path / "ref"))
    assert ref.origin.lat == pytest.approx(own.lat) and ref.origin.alt == pytest.approx(own.alt)
    spec = world_yaml(tmp_path, {"type": fmt, "dir": str(tdir)}, origin=given, spawn={"x_m": -10.0, "y_m": -5.0})
    w = load_world(build_world(spec, tmp_path / "shifted"))
    for x, y in [(0.0, 0.0), (3.3, -4.1), (-7.0, 6.5)]:
        assert w.terrain_height(x - 10.0, y - 5.0) == pytest.approx(ref.terrain_height(x, y) + 2.0, abs=2e-3)
    from vinecli.world.engine import Engine

    with Engine() as e:
        e.load_terrain(w.terrain)
        assert e.ray_height(-10.0 + 3.3, -5.0 - 4.1) == pytest.approx(w.terrain_height(-6.7, -9.1), abs=0.03)
    _check_sdf(tmp_path / "shifted")


def test_world_json_carries_rows_geofence_wind_and_physics(tmp_path):
    spec = world_yaml(
        tmp_path, {"type": "flat", "z_m": 1.5}, origin={"lat": 10.0, "lon": 20.0, "alt": 100.0}, rows="auto",
        wind={"law": {"type": "sinusoid", "mean_mps": 2.0, "amplitude_mps": 1.0, "heading_deg": 90.0}},
        physics_rate_hz=500, gravity_mps2=9.81, air_density_kgm3=1.1,
        geofence={"polygon_enu": [[-5, -5], [5, -5], [5, 5]], "action": "rtl"}, spawn={"x_m": 1.0, "y_m": -1.0,
                                                                                      "yaw_deg": 90.0},
    )
    w = load_world(build_world(spec, tmp_path / "w"))
    assert w.rows_auto and w.vine_rows_enu == []
    assert w.physics_rate_hz == 500 and w.gravity == 9.81 and w.air_density == 1.1
    assert w.wind.law.type == "sinusoid" and w.geofence.action == "rtl"
    assert w.spawn_enu == pytest.approx((1.0, -1.0, 1.5 + w.vehicle.frame.landing_gear_height_m), abs=0.005)
    assert w.spawn_yaw_rad == pytest.approx(math.pi / 2)
    assert w.terrain_height(3.0, 4.0) == 1.5
    sdf = etree.parse(str(tmp_path / "w" / "world.sdf")).getroot()
    assert sdf.findtext("world/wind/linear_velocity") == "2 0 0"  # mean of the sinusoid, towards east
    assert sdf.findtext("world/physics/max_step_size") == "0.002"
