"""The spawn: the sample world's take-off spot is flat (rest attitude reported by world build), and
the runner settles the vehicle at rest before t = 0 (no contact events from the spawn itself)."""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin
from sim_helpers import OpenLoop, mission, world_yaml

from vinecli.autopilot.registry import make_autopilot
from vinecli.sim.runner import run_simulation
from vinecli.specs.mission import MissionSpec
from vinecli.world import build_world, load_world
from vinecli.world.model import rest_position


@pytest.fixture(scope="module")
def sample_dir(tmp_path_factory: pytest.TempPathFactory, repo: Path) -> Path:
    return build_world(repo / "worlds" / "vineyard-sample.yaml", tmp_path_factory.mktemp("vs") / "vineyard-sample")


def test_sample_spawn_is_flat_and_inside_the_geofence(sample_dir: Path) -> None:
    from vinecli.autopilot.geofence import Geofence
    from vinecli.autopilot.preflight import fence_margins_m

    rest = json.loads((sample_dir / "world.json").read_text())["spawn"]["rest"]
    assert rest["settled"] and rest["tilt_deg"] < 5.0 and rest["drift_m"] < 0.05
    w = load_world(sample_dir)
    horiz, _ = Geofence(w.geofence, w.spawn_enu).clearance(w.spawn_enu)
    gnss = w.vehicle.sensors.gnss
    margin = fence_margins_m(gnss.horizontal_noise_m, gnss.vertical_noise_m)[0]
    assert horiz >= margin + 0.2  # 3 sigma of the GNSS noise (0.9 m) and then some
    # the runner's own rest state at t = 0 is as level as the build's
    r = run_simulation(w, mission(max_duration_s=0.5), OpenLoop(lambda o: [0.0] * 4), seed=1)
    assert math.degrees(r.timeseries["tilt_rad"][0]) < 5.0
    assert np.ptp(r.timeseries["pos_enu_z_m"]) < 1e-3 and r.timeseries["on_ground"].all()


def test_takeoff_has_one_liftoff_after_arming(sample_dir: Path) -> None:
    w = load_world(sample_dir)
    m = MissionSpec(name="t", max_duration_s=20.0, tank_fill_l=1.0, phases=[
        {"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "hold", "duration_s": 1.0}, {"type": "land"}])
    ap = make_autopilot("builtin")
    try:
        r = run_simulation(w, m, ap, seed=3)
    finally:
        ap.close()
    assert r.status.value == "completed", r.detail
    lift = [e.t_us for e in r.events if e.kind == "liftoff"]
    armed = [e.t_us for e in r.events if e.kind == "arming" and e.data.get("armed")]
    assert len(lift) == 1 and armed and lift[0] > armed[0]
    assert [e.kind for e in r.events].count("touchdown") == 1


def test_a_ridge_top_spawn_settles_before_t0_without_events(sample_dir: Path) -> None:
    """On a potato ridge top the vehicle tumbles off; that happens while settling, not as a
    'lift-off' with the motors off (the runner used to report liftoff/touchdown here)."""
    w0 = load_world(sample_dir)
    w = dataclasses.replace(w0, spawn_enu=rest_position(w0.terrain, w0.vehicle, 1.96, -7.74), spawn_yaw_rad=2.98)
    r = run_simulation(w, mission(max_duration_s=1.0), OpenLoop(lambda o: [0.0] * 4), seed=1)
    assert [e.kind for e in r.events] == ["status"]
    ts = r.timeseries
    assert ts["on_ground"].all() and np.ptp(ts["pos_enu_z_m"]) < 2e-3
    assert r.metrics["spawn_settle_s"] > 0.1


def test_world_build_warns_about_a_tilted_spawn(tmp_path: Path, caplog: Any) -> None:
    n = 121
    x = np.arange(n) * 0.1
    X, _ = np.meshgrid(x, x)
    z = (400.0 + math.tan(math.radians(15.0)) * X).astype(np.float32)  # a 15 deg slope towards east
    tif = tmp_path / "slope.tif"
    with rasterio.open(tif, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32632",
                       transform=from_origin(465000.0, 5250000.0, 0.1, 0.1)) as ds:
        ds.write(z, 1)
    spec = world_yaml(tmp_path, {"type": "dsm", "path": str(tif), "format": "tiles", "max_error_m": 0.01,
                                 "tile_px": 64})
    with caplog.at_level(logging.WARNING, logger="vinecli.world.build"):
        d = build_world(spec, tmp_path / "w")
    rest = json.loads((d / "world.json").read_text())["spawn"]["rest"]
    assert rest["tilt_deg"] == pytest.approx(15.0, abs=1.5)
    assert any("tilted" in rec.getMessage() for rec in caplog.records)


def _slope_world(tmp_path: Path, slope_deg: float, **kw: Any) -> Path:
    n = 121
    x = np.arange(n) * 0.1
    X, _ = np.meshgrid(x, x)
    z = (400.0 + math.tan(math.radians(slope_deg)) * X).astype(np.float32)  # a slope towards east
    tif = tmp_path / "slope.tif"
    with rasterio.open(tif, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32632",
                       transform=from_origin(465000.0, 5250000.0, 0.1, 0.1)) as ds:
        ds.write(z, 1)
    return world_yaml(tmp_path, {"type": "dsm", "path": str(tif), "format": "tiles", "max_error_m": 0.01,
                                 "tile_px": 64}, **kw)


def test_world_build_refuses_a_spawn_that_cannot_pass_preflight(tmp_path: Path, repo: Path) -> None:
    """Tilted beyond control.preflight_max_tilt_deg at rest: exit 2, one line, nothing written;
    --allow-unsafe-spawn builds it and the run ends preflight_failed before arming."""
    from typer.testing import CliRunner

    from vinecli.cli.app import app
    from vinecli.runs import RunRequest, run_mission

    strict = tmp_path / "strict.yaml"  # the x500 sprayer that refuses to arm above 10 deg (the slope is 15)
    strict.write_text(f"base: {repo / 'vehicles' / 'x500-sprayer.yaml'}\nname: strict\n"
                      "control: {preflight_max_tilt_deg: 10.0}\n")
    spec = _slope_world(tmp_path, 15.0, vehicle=str(strict))
    r = CliRunner().invoke(app, ["world", "build", str(spec), "--out", str(tmp_path / "w")])
    assert r.exit_code == 2, r.output
    assert "unsafe spawn: preflight check 'tilt': tilted 1" in r.output and "limit 10 deg" in r.output
    assert len(r.output.strip().splitlines()) == 1
    assert not (tmp_path / "w").exists() and not list(tmp_path.glob(".w.tmp-*"))
    r = CliRunner().invoke(app, ["world", "build", str(spec), "--out", str(tmp_path / "w"), "--allow-unsafe-spawn"])
    assert r.exit_code == 0, r.output
    (tmp_path / "m.yaml").write_text("name: up\nmax_duration_s: 20\nphases: [{type: takeoff, altitude_agl_m: 2.0}]\n")
    s = run_mission(RunRequest(tmp_path / "m.yaml", tmp_path / "w", tmp_path / "runs", seed=1))
    assert s.status == "preflight_failed" and "'tilt'" in s.status_message and "limit 10 deg" in s.status_message
    events = (tmp_path / "runs" / s.run_id / "events.jsonl").read_text()
    assert '"kind": "preflight"' in events and '"kind": "arming"' not in events


def test_world_build_refuses_a_spawn_near_the_geofence(tmp_path: Path) -> None:
    from vinecli.errors import SpecError

    fence = {"polygon_enu": [[-5.0, -5.0], [0.5, -5.0], [0.5, 5.0], [-5.0, 5.0]]}
    spec = world_yaml(tmp_path, {"type": "flat", "z_m": 0.0, "size_m": 40.0},
                      origin={"lat": 47.0, "lon": 8.0, "alt": 400.0}, geofence=fence)
    with pytest.raises(SpecError, match=r"'geofence_spawn'.*0\.50 m inside, needs 0\.90 m"):
        build_world(spec, tmp_path / "w")
    assert not (tmp_path / "w").exists()
    assert build_world(spec, tmp_path / "w", allow_unsafe_spawn=True).is_dir()
