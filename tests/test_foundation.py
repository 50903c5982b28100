"""Foundation: error -> exit-code mapping, atomic outputs, spec loading with base: inheritance."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from vinecli import __version__
from vinecli.cli.app import app
from vinecli.cli.console import handles_errors
from vinecli.errors import ChecksFailed, InputError, OutputError, RuntimeFailure, SpecError
from vinecli.outputs import Manifest, atomic_output_dir, sha256_file
from vinecli.specs import load_spec
from vinecli.specs.vehicle import VehicleSpec

REPO = Path(__file__).resolve().parents[1]


def test_version_and_groups() -> None:
    r = CliRunner().invoke(app, ["--version"])
    assert r.exit_code == 0 and __version__ in r.stdout
    r = CliRunner().invoke(app, ["--help"])
    assert r.exit_code == 0
    for group in ("terrain", "world", "run", "report", "px4"):
        assert group in r.stdout


@pytest.mark.parametrize(
    ("exc", "code"),
    [(InputError("bad", path="x.tif"), 2), (SpecError("f: unknown field", path="m.yaml"), 2),
     (RuntimeFailure("boom"), 3), (ChecksFailed("1 check failed"), 1), (ValueError("odd"), 3)],
)
def test_error_mapping_one_line_no_traceback(exc: Exception, code: int) -> None:
    mini = typer.Typer()

    @mini.command()
    @handles_errors
    def go() -> None:
        raise exc

    @mini.command()
    def other() -> None:  # a second command keeps Typer in group mode
        """Unused."""

    r = CliRunner().invoke(mini, ["go"])
    assert r.exit_code == code
    assert "Traceback" not in r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("vinecli: error:")
    if getattr(exc, "path", None):
        assert exc.path in lines[0]  # type: ignore[attr-defined]


def test_atomic_output_success_writes_manifest(tmp_path: Path) -> None:
    src = tmp_path / "in.txt"
    src.write_text("hello")
    m = Manifest(command="test", parameters={"n": 3}, inputs=[src])
    out = tmp_path / "out"
    with atomic_output_dir(out, m) as d:
        with m.stage("write"):
            (d / "a.txt").write_text("a")
    man = json.loads((out / "manifest.json").read_text())
    assert man["version"] == __version__ and man["parameters"] == {"n": 3}
    assert man["inputs"][0]["sha256"] == sha256_file(src)
    assert [o["path"] for o in man["outputs"]] == ["a.txt"]
    assert "write" in man["timings_s"]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_atomic_output_failure_leaves_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with pytest.raises(RuntimeError):
        with atomic_output_dir(out, Manifest(command="t")) as d:
            (d / "half.txt").write_text("x")
            raise RuntimeError("fail midway")
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_atomic_output_refuses_non_empty(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    with pytest.raises(OutputError):
        with atomic_output_dir(out, Manifest(command="t")):
            pass
    assert (out / "keep.txt").read_text() == "x"


def test_vehicle_base_inheritance_and_thrust_to_weight() -> None:
    base = load_spec(REPO / "vehicles/x500.yaml", VehicleSpec)
    spr = load_spec(REPO / "vehicles/x500-sprayer.yaml", VehicleSpec)
    assert spr.motor.k_f == base.motor.k_f  # inherited
    assert spr.motor.w_max == 1300.0  # overridden
    assert spr.rotors == base.rotors
    full = spr.dry_mass() + spr.liquid_mass(1.0)
    tw = spr.max_thrust() / (full * 9.80665)
    assert 1.7 < tw < 1.9  # documented 1.78


def test_spec_errors_name_file_and_field(tmp_path: Path) -> None:
    bad = tmp_path / "v.yaml"
    bad.write_text("base: x500.yaml\nmotor: {k_f: -1}\n")
    (tmp_path / "x500.yaml").write_text((REPO / "vehicles/x500.yaml").read_text())
    with pytest.raises(SpecError, match=r"motor\.k_f"):
        load_spec(bad, VehicleSpec)
    bad.write_text("name: [unclosed\n")
    with pytest.raises(SpecError, match="invalid YAML at line"):
        load_spec(bad, VehicleSpec)
    bad.write_text("base: nope.yaml\n")
    with pytest.raises(SpecError, match="not found"):
        load_spec(bad, VehicleSpec)
