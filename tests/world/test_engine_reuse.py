"""A batch worker keeps its world's terrain loaded from one case to the next
(:func:`vinecli.world.engine.reuse_terrain_engines`): the runs must be bit-identical to runs on fresh
engines, whatever ran before on the kept engine, and the engine must really be kept (and dropped
when the terrain changes or a run fails)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from sim_helpers import mission

import vinecli.world.engine as E
from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.sim.runner import run_simulation
from vinecli.world import load_world

FLIGHT = [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "goto", "position_enu": [2.0, 1.0]},
          {"type": "hold", "duration_s": 1.0}, {"type": "land"}]
HOVER = [{"type": "takeoff", "altitude_agl_m": 1.5}, {"type": "hold", "duration_s": 2.0}, {"type": "land"}]


def _fly(world: Any, phases: list[dict[str, Any]], seed: int) -> dict[str, np.ndarray]:
    res = run_simulation(world, mission(phases, max_duration_s=25.0, record_rate_hz=50.0), BuiltinAutopilot(), seed=seed)
    assert res.status.value == "completed", res.detail
    return {k: np.asarray(v) for k, v in res.timeseries.items()}


def _same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)


@pytest.fixture()
def reuse() -> Any:
    E.reuse_terrain_engines()
    yield E._KEPT  # noqa: SLF001 - the test looks at the kept engine
    E.reuse_terrain_engines(False)


def test_runs_on_a_kept_engine_are_bit_identical(bumpy_worlds: dict[str, Path], reuse: Any) -> None:
    world = load_world(bumpy_worlds["tiles"])
    E.reuse_terrain_engines(False)
    fresh_flight, fresh_hover = _fly(world, FLIGHT, 3), _fly(world, HOVER, 4)
    E.reuse_terrain_engines()
    first = _fly(world, HOVER, 4)
    kept = reuse.engine
    assert kept is not None and kept.vehicle == -1 and kept.terrain_bodies  # terrain kept, vehicle removed
    again = [_fly(world, FLIGHT, 3), _fly(world, HOVER, 4), _fly(world, FLIGHT, 3)]
    assert reuse.engine is kept  # the same PyBullet client served every run
    assert _same(first, fresh_hover) and _same(again[1], fresh_hover)
    assert _same(again[0], fresh_flight) and _same(again[2], fresh_flight)


def test_another_terrain_or_a_failed_run_drops_the_engine(bumpy_worlds: dict[str, Path], reuse: Any) -> None:
    tiles, heightmap = load_world(bumpy_worlds["tiles"]), load_world(bumpy_worlds["heightmap"])
    _fly(tiles, HOVER, 1)
    first = reuse.engine
    _fly(heightmap, HOVER, 1)
    assert reuse.engine is not first and first._closed  # noqa: SLF001 - the tiles' engine was closed
    with pytest.raises(RuntimeError), E.terrain_engine(heightmap.terrain, rate_hz=250.0, gravity=9.80665):
        raise RuntimeError("a run failed")
    assert reuse.engine is None
