"""The spawn: the runner settles the vehicle at rest before t = 0 (no contact events from the spawn itself)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from sim_helpers import OpenLoop, mission

from vinecli.autopilot.registry import make_autopilot
from vinecli.sim.runner import run_simulation
from vinecli.specs.mission import MissionSpec
from vinecli.world import build_world, load_world
from vinecli.world.model import rest_position


@pytest.fixture(scope="module")
def sample_dir(tmp_path_factory: pytest.TempPathFactory, repo: Path) -> Path:
    return build_world(repo / "worlds" / "vineyard-sample.yaml", tmp_path_factory.mktemp("vs") / "vineyard-sample")


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
