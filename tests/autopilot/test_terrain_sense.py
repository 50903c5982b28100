"""What the autopilot knows of the terrain: the map alone, the map corrected by the rangefinder
(which also removes the altitude estimate's error from the height above the ground), the rangefinder
alone, and a reading below the sensor's minimum range on the ground."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vinecli.autopilot.terrain import TerrainDatabase, TerrainSense
from vinecli.flight.rangefinder import Rangefinder
from vinecli.frames import quat_from_euler
from vinecli.specs.vehicle import MountSpec, RangefinderSpec
from vinecli.terrain.grid import TerrainGrid
from vinecli.types import RangeSample

LEVEL = (0.0, 0.0, 0.0, 1.0)
GEAR = 0.12
SPEC = RangefinderSpec(noise_m=0.0, mount=MountSpec(position_m=(0.05, 0.0, -0.04)))


def hills() -> TerrainGrid:
    x = np.arange(0.0, 40.01, 0.5)
    z = 3.0 + 1.5 * np.sin(x[None, :] / 5.0) + 0.8 * np.cos(x[:, None] / 7.0)
    return TerrainGrid(z, 0.0, 0.0, 0.5, 0.5)


def fly_over(sense: TerrainSense, grid: TerrainGrid, z_err: float, rf_spec: RangefinderSpec = SPEC) -> list[float]:
    """Fly east at 2 m above the real terrain with an altitude estimate off by ``z_err``; the real
    rangefinder samples the real terrain. Returns the believed terrain minus the real one under the vehicle."""
    rf = Rangefinder(rf_spec, grid.height, 10.0, np.random.default_rng(0))
    errs = []
    q = quat_from_euler(0.05, -0.1, 0.3)
    for k in range(400):
        t = k * 20_000
        x, y = 5.0 + 0.05 * k, 20.0
        z = grid.height(x, y) + 2.0 + GEAR
        sense.update(t, rf.sample(t, (x, y, z), q), (x, y, z + z_err), q, (2.5, 0.0, 0.0), False)
        errs.append(sense.height(x, y) - z_err - grid.height(x, y))
    return errs


def test_map_only_is_the_map() -> None:
    grid = hills()
    sense = TerrainSense(TerrainDatabase(grid), None, 99.0, GEAR)
    sense.update(0, None, (10.0, 12.0, 9.0), LEVEL, (0.0, 0.0, 0.0), True)
    assert sense.height(10.0, 12.0) == grid.height(10.0, 12.0)
    assert sense.height_agl == pytest.approx(9.0 - grid.height(10.0, 12.0) - GEAR)
    assert math.isnan(sense.dist_bottom)  # no rangefinder: no measured distance
    # no map either: flat at the ground under home
    bare = TerrainSense(None, None, 4.0, GEAR)
    assert bare.height(123.0, -5.0) == 4.0


def test_rangefinder_corrects_the_map_for_the_altitude_error() -> None:
    """The altitude estimate is 0.4 m high: with the map alone the autopilot flies 0.4 m low; with the
    rangefinder the believed terrain moves up by the same 0.4 m, so the height above it is the real one."""
    grid = hills()
    errs = fly_over(TerrainSense(TerrainDatabase(grid), SPEC, 0.0, GEAR), grid, 0.4)
    assert max(abs(e) for e in errs[10:]) < 0.01
    sense = TerrainSense(TerrainDatabase(grid), SPEC, 0.0, GEAR)
    fly_over(sense, grid, 0.4)
    assert sense.dist_bottom == pytest.approx(2.0, abs=0.01)  # the skids' real height
    map_only = TerrainSense(TerrainDatabase(grid), None, 0.0, GEAR)
    errs_map = fly_over(map_only, grid, 0.4)
    assert errs_map[-1] == pytest.approx(-0.4)


def test_rangefinder_without_a_map_knows_the_ground_under_the_vehicle() -> None:
    grid = hills()
    sense = TerrainSense(None, SPEC, 0.0, GEAR)
    errs = fly_over(sense, grid, 0.0)
    # the terrain under the vehicle, measured a step earlier where the ray hit (the hills move ~5 cm per step)
    assert max(abs(e) for e in errs[10:]) < 0.1
    assert sense.dist_bottom == pytest.approx(2.0, abs=0.1)


def test_below_the_minimum_range_on_the_ground_reads_the_ground_clearance() -> None:
    spec = RangefinderSpec(noise_m=0.0, min_range_m=0.3, mount=MountSpec(position_m=(0.0, 0.0, -0.04)))
    sense = TerrainSense(TerrainDatabase(None, 10.0), spec, 10.0, GEAR)
    assert sense.ground_range == pytest.approx(GEAR - 0.04)
    pos = (0.0, 0.0, 10.0 + GEAR + 0.1)  # the estimate 0.1 m high, on the ground
    sense.update(0, RangeSample(0, math.nan, False), pos, LEVEL, (0.0, 0.0, 0.0), True)
    assert sense.dist_bottom == pytest.approx(0.0, abs=1e-9) and sense.height(0.0, 0.0) == pytest.approx(10.1)
    # in the air an invalid reading is no reading: the distance lapses after 5 s
    sense.update(6_000_000, RangeSample(6_000_000, math.nan, False), pos, LEVEL, (0.0, 0.0, 0.0), False)
    assert math.isnan(sense.dist_bottom)
