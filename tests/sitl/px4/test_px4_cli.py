"""``vinecli run mission --autopilot px4`` and ``--mavlink`` through the CLI: a built world, the
fake PX4 peer on a dedicated instance's ports, run directories with checks, exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tests.sitl.px4.fake_px4 import FakePx4
from vinecli.cli.app import app

pytestmark = pytest.mark.timeout(240)
runner = CliRunner()
INSTANCE = 83  # TCP 4643, UDP 14623 (vinecli) / 14663 (PX4): away from a PX4 a developer may run on 0..9

MISSION = """\
name: px4-quick
description: takeoff, hold, land flown by PX4
autopilot: px4
vehicle: x500-sprayer
max_duration_s: 60
record_rate_hz: 25
phases:
  - {type: takeoff, altitude_agl_m: 2.5}
  - {type: hold, duration_s: 2}
  - {type: land}
checks:
  - {name: climbed, quantity: metric:altitude_above_home_m, window: ["phase:1", "phase_end:1"], op: between, bound: [2.0, 3.0]}
"""


def test_run_mission_with_px4_through_the_cli(flat_world_dir: Path, tmp_path: Path) -> None:
    from vinecli.world import load_world

    w = load_world(flat_world_dir)
    m = tmp_path / "px4-quick.yaml"
    m.write_text(MISSION)
    fake = FakePx4(w.vehicle, w.origin, instance=INSTANCE, sim_port=4560 + INSTANCE, api_local_port=14580 + INSTANCE,
                   api_remote_port=14540 + INSTANCE).start()
    try:
        r = runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(tmp_path / "runs"),
                                "--px4-instance", str(INSTANCE), "--px4-connect-timeout", "10"])
    finally:
        fake.stop()
    assert r.exit_code == 0, r.output
    assert fake.violations == [] and fake.error is None
    s = json.loads((tmp_path / "runs" / "px4-quick-s0" / "summary.json").read_text())
    assert s["autopilot"] == "px4" and s["status"] == "completed" and s["passed"]
    assert [c["name"] for c in s["checks"]] == ["climbed", "status", "px4_stalls"]  # + the implicit lockstep check
    events = [json.loads(line) for line in (tmp_path / "runs" / "px4-quick-s0" / "events.jsonl").read_text().splitlines()]
    assert any(e["kind"] == "mission_uploaded" for e in events)
    manifest = json.loads((tmp_path / "runs" / "px4-quick-s0" / "manifest.json").read_text())
    assert manifest["parameters"]["px4_instance"] == INSTANCE


def test_px4_never_connecting_is_exit_2_with_the_start_command(flat_world_dir: Path, tmp_path: Path) -> None:
    """An external PX4 that nobody started is the command's set-up problem: exit 2, one line with the command that
    starts it, and no run written (a PX4 that vinecli starts and that fails is an error run, exit 3)."""
    m = tmp_path / "px4-quick.yaml"
    m.write_text(MISSION)
    r = runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(tmp_path / "runs"),
                            "--px4-instance", str(INSTANCE), "--px4-connect-timeout", "0.3"])
    assert r.exit_code == 2
    assert not (tmp_path / "runs").exists()
    err = " ".join(r.stderr.split())
    assert err.startswith("vinecli: error:") and err.count("vinecli: error:") == 1
    assert f"127.0.0.1:{4560 + INSTANCE}" in err and f"px4 -d -i {INSTANCE}" in err
    assert "Traceback" not in r.output


def test_mavlink_non_loopback_needs_the_flag(flat_world_dir: Path, tmp_path: Path) -> None:
    m = tmp_path / "hover.yaml"
    m.write_text(MISSION.replace("autopilot: px4", "autopilot: builtin"))
    r = runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(tmp_path / "runs"),
                            "--mavlink", "udp:192.168.7.7:14540"])
    assert r.exit_code == 2 and "--mavlink-allow-remote" in r.stderr
    r = runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out",
                            str(tmp_path / "runs"), "--autopilot", "px4", "--mavlink", "udp:127.0.0.1:14540"])
    assert r.exit_code == 2 and "serves the built-in autopilot" in r.stderr


def test_px4_bin_that_fails_leaves_a_run_directory_and_exit_3(flat_world_dir: Path, tmp_path: Path) -> None:
    """--px4-bin starts the process itself; one that exits at once gives status error, its log in the message."""
    px4 = tmp_path / "px4build" / "bin" / "px4"
    (tmp_path / "px4build" / "etc" / "init.d-posix").mkdir(parents=True)
    (tmp_path / "px4build" / "etc" / "init.d-posix" / "rcS").write_text("# empty\n")
    px4.parent.mkdir(parents=True)
    px4.write_text("#!/bin/sh\necho 'ERROR [simulator_mavlink] broken build for this test'\nexit 7\n")
    px4.chmod(0o755)
    m = tmp_path / "px4-quick.yaml"
    m.write_text(MISSION)
    r = runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(tmp_path / "runs"),
                            "--px4-bin", str(px4), "--px4-connect-timeout", "10"])
    assert r.exit_code == 3, r.output
    summary = json.loads((tmp_path / "runs" / "px4-quick-s0" / "summary.json").read_text())
    assert summary["status"] == "error"
    assert "PX4 exited (code 7)" in summary["status_message"] and "broken build for this test" in summary["status_message"]


def test_px4_bin_needs_the_px4_autopilot(flat_world_dir: Path, tmp_path: Path) -> None:
    m = tmp_path / "builtin.yaml"
    m.write_text(MISSION.replace("autopilot: px4", "autopilot: builtin"))
    r = runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(tmp_path / "runs"),
                            "--px4-bin", "/bin/sh"])
    assert r.exit_code == 2 and "--px4-bin needs --autopilot px4" in r.output
