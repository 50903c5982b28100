"""The predicted steady tilt atan(|F_h| / (m g)) has one definition (vinecli.missions.metrics), and the
report's figure 21 evaluates it with the gravity of the run's world, not a constant."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.repo_paths import REPO
from vinecli.constants import STANDARD_GRAVITY
from vinecli.missions.metrics import horizontal_aero_force_enu, predicted_tilt_rad
from vinecli.report.plots import load_plot_data
from vinecli.runs.rundir import SUMMARY, world_gravity

from .synth_runs import write_run


def test_predicted_tilt_of_the_link_drag() -> None:
    cols = {"drag_enu_x_n": np.array([3.0, 0.0]), "drag_enu_y_n": np.array([4.0, 0.0]),
            "total_mass_kg": np.array([1.0, 2.0])}
    np.testing.assert_allclose(predicted_tilt_rad(cols, 5.0), [math.pi / 4, 0.0])


def test_the_rotor_h_force_is_rotated_into_enu() -> None:
    """Yawed 90 deg left (FLU x points north): a rotor force along body x adds to the north drag."""
    s = math.sqrt(0.5)
    cols = {"drag_enu_x_n": np.array([1.0]), "drag_enu_y_n": np.array([0.0]), "total_mass_kg": np.array([1.0]),
            "rotor_drag_flu_x_n": np.array([2.0]), "rotor_drag_flu_y_n": np.array([0.0]),
            "rotor_drag_flu_z_n": np.array([0.0]), "quat_x": np.array([0.0]), "quat_y": np.array([0.0]),
            "quat_z": np.array([s]), "quat_w": np.array([s])}
    fx, fy = horizontal_aero_force_enu(cols)
    np.testing.assert_allclose([fx[0], fy[0]], [1.0, 2.0], atol=1e-12)
    assert predicted_tilt_rad(cols, 9.0)[0] == pytest.approx(math.atan2(math.sqrt(5.0), 9.0))


def test_the_report_uses_the_gravity_of_the_runs_world(tmp_path: Path) -> None:
    from vinecli.world import build_world

    spec = tmp_path / "mars-ish.yaml"
    spec.write_text((REPO / "worlds" / "flat.yaml").read_text() + "\ngravity_mps2: 3.71\n")
    world = build_world(spec, tmp_path / "world")
    assert world_gravity({"world": {"dir": str(world)}}) == pytest.approx(3.71)
    assert world_gravity({"world": {"dir": str(tmp_path / "gone")}}) is None
    assert world_gravity({}) is None

    run = write_run(tmp_path / "runs", "gust")
    assert load_plot_data(run).gravity == STANDARD_GRAVITY  # its world (/nonexistent/...) is not here
    summary = json.loads((run / SUMMARY).read_text())
    summary["world"]["dir"] = str(world)
    (run / SUMMARY).write_text(json.dumps(summary))
    assert load_plot_data(run).gravity == pytest.approx(3.71)
