"""Confined references and escaped text. ``base:`` and every spec a spec names resolve
relative to the file that names them and only inside the folders specs may refer to, and only to specs:
``base: /etc/shadow`` is refused unread (on main a file's first line could reach the error). Every user
string printed to the terminal shows its control characters escaped (on main a check name with terminal
escape codes was printed raw)."""

from __future__ import annotations

from pathlib import Path

import pytest
from attack_kit import MISSION, cli, error_line

SECRET = "SECRET_TOKEN_4f9a: hunter2\n"


@pytest.fixture
def project(tmp_path: Path) -> Path:
    """tmp/proj (where the user works) and tmp/secret (somewhere else on the machine)."""
    (tmp_path / "secret").mkdir()
    (tmp_path / "secret" / "shadow").write_text(SECRET)
    (tmp_path / "secret" / "v.yaml").write_text(SECRET)
    (tmp_path / "proj").mkdir()
    return tmp_path / "proj"


def _mission(proj: Path, extra: str) -> Path:
    m = proj / "m.yaml"
    m.write_text(MISSION.format(name="m", maxdur=20, rate=10) + extra)
    return m


@pytest.mark.parametrize(("extra", "said"), [
    ("base: ../secret/shadow\n", "lies outside the folders"),
    ("base: /etc/shadow\n", "lies outside the folders"),
    ("base: notes.txt\n", "not a spec"),
])
def test_a_base_outside_the_allowed_folders_or_not_a_spec_is_refused_unread(flat_world_dir: Path, project: Path,
                                                                           extra: str, said: str) -> None:
    (project / "notes.txt").write_text(SECRET)
    r = cli("run", "mission", _mission(project, extra), "--world", flat_world_dir, "--out", project / "runs")
    assert r.exit_code == 2, r.output
    line = error_line(r)
    assert said in line and "base" in line
    assert "SECRET" not in r.output and "hunter2" not in r.output and "root:" not in r.output


def test_a_vehicle_file_outside_the_allowed_folders_is_refused(flat_world_dir: Path, project: Path) -> None:
    m = _mission(project, "")
    m.write_text(m.read_text().replace("vehicle: x500-sprayer", "vehicle: ../secret/v.yaml"))
    r = cli("run", "mission", m, "--world", flat_world_dir, "--out", project / "runs")
    assert r.exit_code == 2, r.output
    assert "lies outside the folders" in error_line(r) and "SECRET" not in r.output


def test_a_pipeline_mission_outside_the_allowed_folders_is_refused(flat_world_dir: Path, project: Path) -> None:
    (project / "p.yaml").write_text(f"name: p\nworld: {flat_world_dir}\nmissions: [../secret/v.yaml]\n")
    r = cli("run", "batch", project / "p.yaml", "--out", project / "runs")
    assert r.exit_code == 2, r.output
    assert "lies outside the folders" in error_line(r) and "SECRET" not in r.output


def test_specs_may_refer_within_their_folder_and_to_vinecli_s_own(flat_world_dir: Path, project: Path) -> None:
    (project / "sub").mkdir()
    (project / "sub" / "b.yaml").write_text("max_duration_s: 15\n")
    m = _mission(project, "base: sub/b.yaml\n")
    r = cli("run", "mission", m, "--world", flat_world_dir, "--out", project / "runs")
    assert r.exit_code in (0, 1), r.output


ESC = "\x1b[2J\x1b[31m"


def test_check_names_with_terminal_escapes_are_printed_escaped(flat_world_dir: Path, tmp_path: Path) -> None:
    m = tmp_path / "m.yaml"
    m.write_text(MISSION.format(name="m", maxdur=20, rate=10)
                 + f'checks:\n  - {{name: "{ESC.encode("unicode_escape").decode()}pwned [/]", quantity: pos_enu_z_m,'
                   ' reduce: max, op: "<", bound: -1.0}\n')
    r = cli("run", "mission", m, "--world", flat_world_dir, "--out", tmp_path / "runs")
    assert r.exit_code == 1, r.output  # the check fails, nothing crashes on the name
    assert "\x1b" not in r.output
    assert "\\x1b[2J" in r.output and "pwned [/]" in " ".join(r.output.split())
    r = cli("run", "checks", tmp_path / "runs" / "m-s0")
    assert r.exit_code == 1 and "\x1b" not in r.output


def test_error_lines_show_control_characters_escaped(flat_world_dir: Path, tmp_path: Path) -> None:
    m = tmp_path / "m.yaml"
    m.write_text(MISSION.format(name="m", maxdur=20, rate=10) + f'"{ESC.encode("unicode_escape").decode()}": 1\n')
    r = cli("run", "mission", m, "--world", flat_world_dir, "--out", tmp_path / "runs")
    assert r.exit_code == 2, r.output
    assert "\x1b" not in r.output and "\\x1b[2J" in error_line(r)
