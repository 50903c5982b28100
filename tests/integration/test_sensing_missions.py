"""The built-in autopilot senses its landing through the real loop (PyBullet, sensors, rangefinder):
the land detector's ``land_detected`` follows the simulator's ground-truth touchdown by PX4's ~1 s
(ground contact, maybe landed, landed, 1/3 s each), with the rangefinder (x500-sprayer) and with
the terrain map only (x500); a ground-truth run flies the simulator's perfect estimator through the
same interface."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from vinecli.autopilot.base import Autopilot, AutopilotContext, AutopilotStatus, RunStatus
from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.autopilot.estimator import Estimator
from vinecli.sim.perfect_estimator import PerfectEstimator
from vinecli.specs.mission import MissionSpec
from vinecli.types import ActuatorCommand, Event, Observation
from vinecli.vehicle import load_vehicle

PHASES = [{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "hold", "duration_s": 2.0}, {"type": "land"}]


@pytest.fixture(scope="module")
def flat(tmp_path_factory: pytest.TempPathFactory, repo: Path) -> Any:
    from vinecli.world import build_world, load_world

    return load_world(build_world(repo / "worlds" / "flat.yaml", tmp_path_factory.mktemp("w") / "flat"))


class Recording(Autopilot):
    """The built-in autopilot, remembering the context it was given and the largest gap between the
    position it flew on and the true one (the test reads the truth, the autopilot does not). It wraps the
    autopilot instead of subclassing it: the compiled kernel's classes take no interpreted subclasses."""

    def __init__(self) -> None:
        self.inner = BuiltinAutopilot()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)

    def reset(self, ctx: AutopilotContext) -> None:
        self.ctx_given = ctx
        self.max_pos_gap = 0.0
        self.inner.reset(ctx)

    def step(self, obs: Observation) -> ActuatorCommand:
        cmd = self.inner.step(obs)
        gap = max(abs(a - b) for a, b in zip(self.inner.pos, obs.truth.pos, strict=True))
        self.max_pos_gap = max(self.max_pos_gap, gap)
        return cmd

    def status(self) -> AutopilotStatus:
        return self.inner.status()

    def drain_events(self) -> list[Event]:
        return self.inner.drain_events()

    def close(self) -> None:
        self.inner.close()


def fly(world: Any, vehicle: str, *, truth: bool = False) -> tuple[Any, Recording]:
    from vinecli.sim.runner import run_simulation

    ap = Recording()
    res = run_simulation(world, MissionSpec(name="t", truth=truth, max_duration_s=30.0, phases=PHASES), ap,
                         vehicle=load_vehicle(vehicle), seed=3)
    return res, ap


@pytest.mark.parametrize("vehicle", ["x500-sprayer", "x500"])
def test_touchdown_detected_from_own_signals_within_px4s_second(flat: Any, vehicle: str) -> None:
    res, ap = fly(flat, vehicle)
    assert res.status is RunStatus.COMPLETED, res.detail
    assert (load_vehicle(vehicle).sensors.rangefinder is not None) == ap.terrain_sense.has_range
    t_td = next(e.t_us for e in res.events if e.kind == "touchdown") * 1e-6  # the simulator's truth
    t_ld = next(e.t_us for e in res.events if e.kind == "land_detected") * 1e-6  # the autopilot's own
    assert 0.9 <= t_ld - t_td <= 1.6
    assert res.timeseries["armed"][-1] == 0.0
    assert res.metrics["max_impact_speed_mps"] < 1.2
    # it flew on its own estimator and learnt the full tank's mass in the air
    assert isinstance(ap.estimator, Estimator) and ap.ctx_given.estimator is None
    mass = float(res.timeseries["total_mass_kg"][0])
    assert ap.mass == pytest.approx(mass, rel=0.03)


def test_ground_truth_runs_fly_the_simulators_perfect_estimator(flat: Any) -> None:
    res, ap = fly(flat, "x500-sprayer", truth=True)
    assert res.status is RunStatus.COMPLETED, res.detail
    assert isinstance(ap.ctx_given.estimator, PerfectEstimator) and ap.estimator is ap.ctx_given.estimator
    assert ap.max_pos_gap == 0.0  # it flew on the true position, step by step
    own, ap_own = fly(flat, "x500-sprayer")
    assert ap_own.max_pos_gap > 0.05  # ... which its own estimator does not know
