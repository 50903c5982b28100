"""The built-in autopilot only senses: no module of ``vinecli/autopilot`` reads the simulator's truth
(``obs.truth`` or any ``.truth``), a terrain height or a total mass handed over by the simulator, and
the truth mode is the simulator's business (its perfect estimator, outside ``vinecli/autopilot``).
The firmware bridges, simulator-side as PX4's Gazebo bridge, live in ``vinecli/sitl``."""

from __future__ import annotations

import ast
from pathlib import Path

import vinecli

AUTOPILOT = Path(vinecli.__file__).parent / "autopilot"
FORBIDDEN = {"truth", "terrain_height_m", "total_mass_kg", "on_ground"}


def test_no_autopilot_module_reads_the_simulators_state() -> None:
    reads = []
    for path in sorted(AUTOPILOT.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and node.attr in FORBIDDEN:
                reads.append(f"{path.name}:{node.lineno} .{node.attr}")
    assert reads == []


def test_the_perfect_estimator_lives_with_the_simulator() -> None:
    from vinecli.autopilot.estimate import StateEstimate
    from vinecli.sim.perfect_estimator import PerfectEstimator

    assert issubclass(PerfectEstimator, StateEstimate)
    assert not PerfectEstimator.__module__.startswith("vinecli.autopilot")
