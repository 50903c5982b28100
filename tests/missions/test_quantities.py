"""Check quantities (and metric/status bounds) are resolved when the mission loads, so a typo
is exit 2 before simulating instead of a failed check after the whole run."""

from __future__ import annotations

from pathlib import Path

import pytest
from repo_paths import REPO
from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.errors import SpecError
from vinecli.missions.quantities import known_metrics, quantity_problem
from vinecli.missions.spec_io import load_mission

runner = CliRunner()

MISSION = """\
name: q
vehicle: x500-sprayer
tank_fill_l: 0.5
max_duration_s: 20
record_rate_hz: 25
phases:
  - {{type: takeoff, altitude_agl_m: 1.5}}
  - {{type: land}}
checks:
  - {check}
"""


def mission(tmp_path: Path, check: str) -> Path:
    p = tmp_path / "q.yaml"
    p.write_text(MISSION.format(check=check))
    return p


@pytest.mark.parametrize(("check", "needle"), [
    ("{name: c, quantity: pos_enu_zz_m, reduce: max, op: '<', bound: 3}", "did you mean 'pos_enu_z_m'"),
    ("{name: c, quantity: 'metric:hpos_eror_max_m', op: '<', bound: 3}", "did you mean 'hpos_error_max_m'"),
    ("{name: c, quantity: pos_enu_z_m, op: '<', bound: max_altitud}", "checks.0.bound: unknown metric"),
    ("{name: c, quantity: 'metric:liftoff_s', op: within_pct, bound: 5, reference: 'metric:nope'}",
     "checks.0.reference"),
    ("{name: c, quantity: status, op: '==', bound: complete}", "did you mean 'completed'"),
    ("{name: c, quantity: rotor0_w_radps, op: '<', bound: 3}", "rotors 1.."),
])
def test_unknown_quantities_fail_at_load(tmp_path: Path, check: str, needle: str) -> None:
    p = mission(tmp_path, check)
    with pytest.raises(SpecError) as exc:
        load_mission(p)
    assert needle in str(exc.value) and str(p) in str(exc.value)


def test_known_quantities_load() -> None:
    for q in ("status", "pos_enu_z_m", "rotor4_thrust_n", "metric:liftoff_s", "metric:hpos_error_max_m",
              "sp_pos_enu_x_m", "tank_force_grav_enu_z_n"):
        assert quantity_problem(q, 4) is None, q
    assert quantity_problem("rotor5_w_radps", 4) is not None
    for f in sorted((REPO / "pipelines" / "missions").glob("*.yaml")):
        load_mission(f)


def test_rotor_beyond_the_vehicle_exits_2_before_simulating(flat_world_dir: Path, tmp_path: Path) -> None:
    p = mission(tmp_path, "{name: c, quantity: rotor6_w_radps, reduce: max, op: '<', bound: 3000}")
    load_mission(p)  # the vehicle is known only with the world: accepted at load
    r = runner.invoke(app, ["run", "mission", str(p), "-w", str(flat_world_dir), "--out", str(tmp_path / "runs")])
    assert r.exit_code == 2
    assert "checks.0.quantity" in r.stderr and "rotors 1..4" in r.stderr
    assert not (tmp_path / "runs").exists()


def test_typo_exits_2_not_1(flat_world_dir: Path, tmp_path: Path) -> None:
    p = mission(tmp_path, "{name: c, quantity: pos_enu_zz_m, reduce: max, op: '<', bound: 3}")
    r = runner.invoke(app, ["run", "mission", str(p), "-w", str(flat_world_dir), "--out", str(tmp_path / "runs")])
    assert r.exit_code == 2 and "pos_enu_zz_m" in r.stderr
    assert not (tmp_path / "runs").exists()


def test_every_metric_a_real_run_reports_is_known(flat_world_dir: Path, tmp_path: Path) -> None:
    """SIMULATOR_METRICS lists what the loop reports: a check may name any summary metric."""
    from vinecli.runs import RunRequest, run_mission

    p = mission(tmp_path, "{name: c, quantity: pos_enu_z_m, reduce: max, op: '>', bound: 1}")
    s = run_mission(RunRequest(p, flat_world_dir, tmp_path / "runs"))
    assert s.metrics and set(s.metrics) <= known_metrics(), set(s.metrics) - known_metrics()
