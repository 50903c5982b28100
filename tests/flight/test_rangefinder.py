"""The rangefinder model against geometry: the distance along the sensor axis to flat, tilted and
stepped terrain (a real height grid), the mount's lever arm and tilt, the range limits, the rate,
the noise, and the slope bound of the ray march."""

from __future__ import annotations

import math
import statistics

import numpy as np
import pytest

from vinecli.flight.rangefinder import Rangefinder, make_rangefinder, ray_terrain_distance
from vinecli.flight.sensors import make_sensors
from vinecli.frames import quat_from_euler
from vinecli.specs.vehicle import MountSpec, RangefinderSpec, SensorsSpec
from vinecli.terrain.grid import TerrainGrid
from vinecli.types import RigidState

LEVEL = (0.0, 0.0, 0.0, 1.0)


def flat(z0: float):  # noqa: ANN201
    return lambda x, y: z0


def sensor(height, slope: float = 0.0, **spec: object) -> Rangefinder:  # noqa: ANN001
    return Rangefinder(RangefinderSpec(noise_m=0.0, **spec), height, slope, np.random.default_rng(0))  # type: ignore[arg-type]


def test_level_over_flat_ground_is_the_height_of_the_sensor() -> None:
    rf = sensor(flat(2.0), mount=MountSpec(position_m=(0.1, -0.05, -0.04)))
    assert rf.true_distance((3.0, 4.0, 7.0), LEVEL) == pytest.approx(7.0 - 0.04 - 2.0, abs=1e-4)


@pytest.mark.parametrize("tilt_deg", [5.0, 20.0, 40.0])
def test_tilted_body_over_flat_ground_reads_h_over_cos(tilt_deg: float) -> None:
    rf = sensor(flat(0.0))
    q = quat_from_euler(math.radians(tilt_deg), 0.0, 0.3)
    assert rf.true_distance((0.0, 0.0, 5.0), q) == pytest.approx(5.0 / math.cos(math.radians(tilt_deg)), abs=1e-4)


def test_level_over_a_slope_and_a_tilted_mount() -> None:
    """Plane z = a x; the mount pitched by -p (FLU: its down axis turns forward): the ray
    (sin p, 0, -cos p) from (0, 0, h) meets the plane at s = h / (cos p + a sin p)."""
    a, h, p = 0.3, 6.0, math.radians(25.0)
    rf = sensor(lambda x, y: a * x, slope=a, mount=MountSpec(rpy_deg=(0.0, -25.0, 0.0)))
    assert rf.true_distance((0.0, 0.0, h), LEVEL) == pytest.approx(h / (math.cos(p) + a * math.sin(p)), abs=1e-4)


def test_a_wall_on_a_height_grid_is_seen_first() -> None:
    """A 2 m step 1 m ahead on a 0.1 m grid: a ray pitched forward hits the wall's face, not the ground
    behind it; the grid's slope bound (the step over one cell) keeps the march from passing through it."""
    z = np.zeros((101, 101))
    z[:, 60:] = 2.0  # x = -5 + 0.1 ix >= 1.0
    grid = TerrainGrid(z, -5.0, -5.0, 0.1, 0.1)
    slope = grid.max_slope()
    assert slope == pytest.approx(20.0)  # 2 m over one 0.1 m cell
    rf = sensor(grid.height, slope, mount=MountSpec(rpy_deg=(0.0, -45.0, 0.0)), max_range_m=20.0)
    d = rf.true_distance((0.0, 0.0, 3.0), LEVEL)
    # the ray x = s/√2, z = 3 - s/√2 meets the bilinear ramp z = 20 (x - 0.9) (0.9 <= x <= 1.0)
    xs = (3.0 + 18.0) / 21.0
    assert d == pytest.approx(xs * math.sqrt(2.0), abs=1e-3)


def test_range_limits_and_no_return_give_invalid_samples() -> None:
    rf = sensor(flat(0.0), min_range_m=0.3, max_range_m=10.0)
    s = rf.sample(0, (0.0, 0.0, 12.0), LEVEL)
    assert s is not None and not s.valid and math.isnan(s.distance_m)
    s = rf.sample(50_000, (0.0, 0.0, 0.2), LEVEL)
    assert s is not None and not s.valid
    s = rf.sample(100_000, (0.0, 0.0, 5.0), quat_from_euler(math.radians(100.0), 0.0, 0.0))  # pointing up
    assert s is not None and not s.valid
    s = rf.sample(150_000, (0.0, 0.0, 5.0), LEVEL)
    assert s is not None and s.valid and s.distance_m == pytest.approx(5.0, abs=1e-4)


def test_rate_on_the_integer_microsecond_grid() -> None:
    rf = sensor(flat(0.0), rate_hz=20.0)
    due = [t for t in range(0, 1_000_000, 4_000) if rf.sample(t, (0.0, 0.0, 3.0), LEVEL) is not None]
    assert [t // 50_000 for t in due] == list(range(20))  # one sample in each 50 ms slot


def test_noise_has_the_spec_sigma_and_its_own_stream() -> None:
    spec = RangefinderSpec(noise_m=0.05, rate_hz=250.0)
    rf = make_rangefinder(spec, flat(0.0), 0.0, seed=7)
    assert rf is not None
    d = [rf.sample(k * 4_000, (0.0, 0.0, 4.0), LEVEL).distance_m for k in range(4000)]  # type: ignore[union-attr]
    assert statistics.fmean(d) == pytest.approx(4.0, abs=0.005)
    assert statistics.pstdev(d) == pytest.approx(0.05, rel=0.05)
    # the other sensors draw the same noise with or without a rangefinder
    truth = RigidState(0, (0.0, 0.0, 4.0), LEVEL, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    a = make_sensors(SensorsSpec(), _origin(), 7).sample_all(truth)
    b = make_sensors(SensorsSpec(rangefinder=spec), _origin(), 7).sample_all(truth)
    assert a[0] == b[0] and a[1] == b[1]
    assert make_rangefinder(None, flat(0.0), 0.0, 7) is None


def test_ray_march_agrees_with_a_fine_scan_on_rough_terrain() -> None:
    rng = np.random.default_rng(3)
    z = rng.uniform(0.0, 1.5, (41, 41))
    grid = TerrainGrid(z, -10.0, -10.0, 0.5, 0.5)
    slope = grid.max_slope()
    for k in range(20):
        o = (float(rng.uniform(-4, 4)), float(rng.uniform(-4, 4)), 4.0)
        tilt, yaw = float(rng.uniform(0.0, 0.6)), float(rng.uniform(-3.0, 3.0))
        u = (math.sin(tilt) * math.cos(yaw), math.sin(tilt) * math.sin(yaw), -math.cos(tilt))
        d = ray_terrain_distance(o, u, grid.height, slope, 20.0)
        s = np.arange(0.0, 20.0, 1e-3)
        clear = o[2] + s * u[2] - grid.heights(o[0] + s * u[0], o[1] + s * u[1])
        first = s[np.argmax(clear <= 0.0)]
        assert d == pytest.approx(first, abs=2e-3), k


def _origin():  # noqa: ANN202
    from vinecli.geo import GeoOrigin

    return GeoOrigin(45.0, 8.0, 200.0)
