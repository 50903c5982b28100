"""Ground contact on mesh tiles, a heightfield and a plane: no jitter at rest, no tunnelling."""

from __future__ import annotations

import numpy as np
import pytest
from sim_helpers import OpenLoop, mission

from vinecli.errors import TerrainError
from vinecli.sim.runner import run_simulation
from vinecli.terrain.grid import TerrainGrid
from vinecli.world import load_world
from vinecli.world.engine import Engine
from vinecli.world.model import TerrainInfo


@pytest.mark.parametrize("kind", ["tiles", "heightmap"])
def test_rests_on_terrain_without_jitter(bumpy_worlds, kind):
    w = load_world(bumpy_worlds[kind])
    assert w.terrain.kind == kind
    r = run_simulation(w, mission(max_duration_s=2.5), OpenLoop(lambda o: [0.0] * 4), seed=1)
    ts = r.timeseries
    settled = ts["t_s"] >= 0.5
    z = ts["pos_enu_z_m"][settled]
    assert z.std() < 1e-3
    assert np.ptp(ts["pos_enu_x_m"][settled]) < 1e-3 and np.ptp(ts["pos_enu_y_m"][settled]) < 1e-3
    assert ts["on_ground"][settled].all()
    # resting on the surface (skids within 3 cm of the grid height under the box)
    assert abs(z[-1] - (w.terrain_height(*r.timeseries["pos_enu_x_m"][-1:], *r.timeseries["pos_enu_y_m"][-1:])
                        + w.vehicle.frame.landing_gear_height_m)) < 0.2
    assert r.metrics["max_impact_speed_mps"] < 0.2


@pytest.mark.parametrize("kind", ["tiles", "heightmap"])
def test_drop_from_two_metres_does_not_tunnel(bumpy_worlds, kind):
    w = load_world(bumpy_worlds[kind])
    phase = {"type": "open_loop", "duration_s": 3.0, "rotor_speeds_rad_s": 0.0,
             "initial_state": {"position_enu": [1.0, -2.0, 2.0]}}
    r = run_simulation(w, mission([phase], max_duration_s=3.0), OpenLoop(lambda o: [0.0] * 4), seed=2,
                       end_on_crash=False)
    ts = r.timeseries
    ground = w.terrain_height(1.0, -2.0)
    lgh = w.vehicle.frame.landing_gear_height_m
    assert ts["pos_enu_z_m"].min() > ground + lgh - 0.15  # never below the surface
    end = ts["t_s"] >= 2.0
    assert ts["on_ground"][end].all()
    assert ts["pos_enu_z_m"][end].std() < 1e-3
    assert [e.kind for e in r.events].count("crash") == 1  # 6.3 m/s impact is a crash
    assert r.metrics["max_impact_speed_mps"] == pytest.approx(np.sqrt(2 * 9.80665 * 2.0), rel=0.05)


def test_crash_ends_the_run(flat_world):
    phase = {"type": "open_loop", "duration_s": 3.0, "rotor_speeds_rad_s": 0.0,
             "initial_state": {"position_enu": [0.0, 0.0, 2.0]}}
    r = run_simulation(flat_world, mission([phase], max_duration_s=3.0), OpenLoop(lambda o: [0.0] * 4), seed=2)
    assert r.status.value == "crashed"
    assert r.sim_time_s == pytest.approx(np.sqrt(2 * 2.0 / 9.80665), abs=0.02)


def test_heightfield_above_2_to_21_samples_is_refused():
    g = TerrainGrid(np.zeros((1449, 1449)), 0.0, 0.0, 1.0, 1.0)
    with Engine() as e, pytest.raises(TerrainError, match="2\\^21"):
        e.load_terrain(TerrainInfo("heightmap", grid=g))


def test_heightfield_matches_grid_heights():
    xs = np.arange(65) * 0.5 - 10
    ys = np.arange(33) * 0.5 + 3
    X, Y = np.meshgrid(xs, ys)
    g = TerrainGrid(0.1 * X + 0.3 * Y + 0.5 * np.sin(X), xs[0], ys[0], 0.5, 0.5)
    with Engine() as e:
        e.load_terrain(TerrainInfo("heightmap", grid=g))
        for x, y in [(0.0, 5.0), (-9.0, 3.5), (5.0, 10.0), (5.5, 11.5)]:
            assert e.ray_height(x, y) == pytest.approx(g.height(x, y), abs=1e-5)
