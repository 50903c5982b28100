"""NaN/inf and absurd magnitudes in any spec are load errors (exit 2, one line naming the
file and the field), alias bombs and huge sweeps are refused before anything is expanded."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from repo_paths import REPO
from typer.testing import CliRunner

from vinecli.batch.pipeline import expand_cases, load_pipeline
from vinecli.cli.app import app
from vinecli.errors import SpecError
from vinecli.missions.spec_io import load_mission
from vinecli.specs import load_spec, read_yaml, resolve_base
from vinecli.specs.vehicle import VehicleSpec
from vinecli.world.spec import WorldSpec

runner = CliRunner()

MISSION = {
    "name": "m", "vehicle": "x500-sprayer", "max_duration_s": 30, "record_rate_hz": 25,
    "phases": [{"type": "takeoff", "altitude_agl_m": 2.0},
               {"type": "goto", "position_enu": [1.0, 1.0]},
               {"type": "waypoints", "waypoints": [[0.0, 0.0, 2.0]]},
               {"type": "land"}],
}


def _set(d: dict, dotted: str, value: object) -> dict:
    import copy

    d = copy.deepcopy(d)
    cur = d
    parts = dotted.split(".")
    for p in parts[:-1]:
        cur = cur[int(p)] if isinstance(cur, list) else cur.setdefault(p, {})
    last = parts[-1]
    if isinstance(cur, list):
        cur[int(last)] = value
    else:
        cur[last] = value
    return d


@pytest.mark.parametrize(("dotted", "value", "field"), [
    ("phases.1.position_enu", [float("nan"), 1.0], "position_enu"),
    ("phases.2.waypoints", [[0.0, float("nan"), 2.0]], "waypoints"),
    ("phases.2.waypoints", [[1e12, 0.0, 2.0]], "waypoints"),
    ("max_duration_s", float("inf"), "max_duration_s"),
    ("max_duration_s", 1e12, "max_duration_s"),
    ("record_rate_hz", float("nan"), "record_rate_hz"),
    ("wind", {"law": {"type": "constant", "velocity_enu": [float("nan"), 0, 0]}}, "wind"),
    ("wind", {"law": {"type": "constant", "velocity_enu": [1e12, 0, 0]}}, "wind"),
    ("wind", {"law": {"type": "dryden", "mean_mps": 1e12}}, "wind"),
    ("wind", {"law": {"type": "sinusoid", "amplitude_mps": 2, "period_s": float("inf")}}, "wind"),
    ("phases.0.timeout_s", 1e300, "timeout_s"),
    ("tank_fill_l", float("-inf"), "tank_fill_l"),
])
def test_mission_numbers_must_be_finite_and_sane(tmp_path: Path, dotted: str, value: object, field: str) -> None:
    p = tmp_path / "m.yaml"
    p.write_text(yaml.safe_dump(_set(MISSION, dotted, value)))
    with pytest.raises(SpecError, match=field) as exc:
        load_mission(p)
    assert str(p) in str(exc.value)


def test_vehicle_world_and_pipeline_numbers_are_checked_too(tmp_path: Path) -> None:
    src = REPO / "vehicles" / "x500-sprayer.yaml"
    veh = resolve_base(src, read_yaml(src))
    veh["frame"] = {**veh["frame"], "mass_kg": float("nan")}
    (tmp_path / "v.yaml").write_text(yaml.safe_dump(veh))
    with pytest.raises(SpecError, match="frame.mass_kg"):
        load_spec(tmp_path / "v.yaml", VehicleSpec)
    (tmp_path / "w.yaml").write_text("name: w\norigin: {lat: 47, lon: 8}\nspawn: {x_m: .nan}\n")
    with pytest.raises(SpecError, match="spawn.x_m"):
        load_spec(tmp_path / "w.yaml", WorldSpec)
    (tmp_path / "p.yaml").write_text("name: p\ntimeout_s: .inf\nmissions: [m.yaml]\n")
    with pytest.raises(SpecError, match="timeout_s"):
        load_pipeline(tmp_path / "p.yaml")


def test_cli_nan_goto_exits_2_before_simulating(tmp_path: Path) -> None:
    p = tmp_path / "m.yaml"
    p.write_text(yaml.safe_dump(_set(MISSION, "phases.1.position_enu", [float("nan"), 0.0])))
    r = runner.invoke(app, ["run", "mission", str(p), "--world", str(tmp_path / "no-world"), "--out",
                            str(tmp_path / "runs")])
    assert r.exit_code == 2
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "position_enu" in lines[0] and "finite" in lines[0]
    assert not (tmp_path / "runs").exists()


BOMB = """\
name: bomb
world: w
sweep:
  mission: m.yaml
  matrix:
    a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1]
    b: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]
    c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]
    d: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c]
    e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d]
    f: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e]
    g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f]
    h: &h [*g, *g, *g, *g, *g, *g, *g, *g, *g]
    i: &i [*h, *h, *h, *h, *h, *h, *h, *h, *h]
"""


def test_yaml_alias_bomb_is_refused(tmp_path: Path) -> None:
    (tmp_path / "p.yaml").write_text(BOMB)
    with pytest.raises(SpecError, match="alias"):
        load_pipeline(tmp_path / "p.yaml")


def test_recursive_alias_is_refused(tmp_path: Path) -> None:
    (tmp_path / "p.yaml").write_text("name: p\nloop: &x [1, *x]\n")
    with pytest.raises(SpecError, match="itself|recursive"):
        read_yaml(tmp_path / "p.yaml")


def test_shared_aliases_within_bounds_still_load(tmp_path: Path) -> None:
    (tmp_path / "p.yaml").write_text("name: p\nvals: &v [1, 2, 3]\nmore: [*v, *v, *v]\n")
    assert read_yaml(tmp_path / "p.yaml")["more"][2] == [1, 2, 3]


def test_huge_sweep_is_refused_before_expanding(tmp_path: Path) -> None:
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(MISSION))
    (tmp_path / "w").mkdir()
    ten = "[1, 2, 3, 4, 5, 6, 7, 8, 9, 10]"
    axes = "".join(f"    {k}: {ten}\n" for k in ("phases.0.altitude_agl_m", "phases.0.timeout_s",
                                                   "phases.1.speed_mps", "phases.3.descent_speed_mps"))
    (tmp_path / "p.yaml").write_text(f"name: p\nworld: w\nsweep:\n  mission: m.yaml\n  seeds: 20\n  matrix:\n{axes}")
    spec = load_pipeline(tmp_path / "p.yaml")
    with pytest.raises(SpecError, match="200,000 cases"):
        expand_cases(spec, tmp_path / "p.yaml")


@pytest.mark.parametrize("timeout", [float("nan"), float("inf"), -1.0, 1e12])
def test_batch_timeout_option_is_checked(tmp_path: Path, timeout: float) -> None:
    from vinecli.batch import run_batch
    from vinecli.errors import InputError

    (tmp_path / "p.yaml").write_text("name: p\nmissions: [m.yaml]\n")
    with pytest.raises(InputError, match="--timeout"):
        run_batch(tmp_path / "p.yaml", tmp_path / "runs", timeout_s=timeout)
    assert not (tmp_path / "runs").exists()


def test_generated_missions_respect_the_limits() -> None:
    """`plan rows` options beyond the limits are exit 2; a huge field's time limit is capped, not refused."""
    from vinecli.errors import InputError
    from vinecli.missions.patterns import spray_mission
    from vinecli.specs.limits import MAX_DURATION_S

    with pytest.raises(InputError, match="speed_mps"):
        spray_mission([[(0.0, 0.0), (10.0, 0.0)]], speed_mps=1e9)
    assert spray_mission([[(0.0, 0.0), (90_000.0, 0.0)]] * 30, speed_mps=0.1).max_duration_s == MAX_DURATION_S
