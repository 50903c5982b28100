"""`vinecli px4 doctor` and the run-autopilot factory (mission <-> item conversion: tests/phase_items/test_phase_items.py)."""

from __future__ import annotations

import socket
import threading

import pytest
from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.errors import InputError
from vinecli.sitl.options import AutopilotOptions, make_run_autopilot
from vinecli.sitl.px4.doctor import px4_doctor

pytestmark = pytest.mark.timeout(60)


def fake_px4_tree(tmp_path):
    b = tmp_path / "PX4-Autopilot" / "build" / "px4_sitl_default"
    (b / "bin").mkdir(parents=True)
    (b / "etc" / "init.d-posix").mkdir(parents=True)
    (b / "etc" / "init.d-posix" / "rcS").write_text("# rcS\n")
    exe = b / "bin" / "px4"
    exe.write_text("#!/bin/sh\nexit 0\n")
    exe.chmod(0o755)
    return exe


def test_doctor_with_binary_prints_exact_command(tmp_path):
    exe = fake_px4_tree(tmp_path)
    r = CliRunner().invoke(app, ["px4", "doctor", "--px4-bin", str(exe), "--instance", "3", "--timeout", "0.2"])
    assert r.exit_code == 0, r.output
    etc = exe.parent.parent / "etc"
    assert (f"PATH=/tmp/px4-sitl-3/rc:$PATH PX4_SIM_MODEL=none_iris {exe} -d -i 3 "
            f"-w /tmp/px4-sitl-3/rootfs {etc}") in r.output.replace("\n", "")
    assert "4563" in r.output and "14543" in r.output


def test_doctor_missing_binary_and_busy_port_fail(tmp_path):
    busy = socket.socket()
    busy.bind(("127.0.0.1", 4560 + 77))
    try:
        rep = px4_doctor(tmp_path / "nope" / "px4", instance=77, probe_timeout_s=0.2)
        st = {c.name.split(" (")[0]: c.status for c in rep.checks}
        assert st["PX4 binary"] == "fail" and st["TCP 127.0.0.1:4637"] == "fail" and not rep.ok
        r = CliRunner().invoke(app, ["px4", "doctor", "--px4-bin", str(tmp_path / "nope" / "px4"), "-i", "77",
                                     "--timeout", "0.2"])
        assert r.exit_code == 1
        assert "not found" in r.output and "in use" in r.output
    finally:
        busy.close()
    with pytest.raises(InputError):
        px4_doctor(instance=120)


def test_doctor_finds_a_running_px4(tmp_path):
    """A PX4-like API endpoint on UDP 14580+i answers the doctor's heartbeat."""
    from vinecli.mavlink.link import UdpLink
    from vinecli.mavlink.vehicle import Telemetry, VehicleEndpoint

    instance = 61
    link = UdpLink(("127.0.0.1", 14580 + instance), ("127.0.0.1", 14540 + instance), src_system=instance + 1)
    ep = VehicleEndpoint(link, handler=None, sysid=instance + 1)  # type: ignore[arg-type]
    stop = threading.Event()

    def serve() -> None:
        t = 0.0
        while not stop.is_set():
            ep.update(t, Telemetry())
            t += 0.05
            stop.wait(0.05)

    th = threading.Thread(target=serve)
    th.start()
    try:
        rep = px4_doctor(instance=instance, probe_timeout_s=3.0)
        assert rep.px4_running
        c = next(c for c in rep.checks if c.name.startswith("PX4 on UDP"))
        assert c.status == "ok" and "autopilot 12, system 62" in c.detail
    finally:
        stop.set()
        th.join()
        link.close()


def test_run_autopilot_factory():
    from vinecli.autopilot.builtin import BuiltinAutopilot
    from vinecli.autopilot.mavlink_vehicle import MavlinkControlledAutopilot
    from vinecli.sitl.px4.backend import Px4SitlAutopilot

    assert isinstance(make_run_autopilot("builtin"), BuiltinAutopilot)
    ap = make_run_autopilot("px4", AutopilotOptions(px4_instance=4, px4_connect_timeout_s=5))
    assert isinstance(ap, Px4SitlAutopilot) and ap.port == 4564 and ap.connect_timeout_s == 5
    ap = make_run_autopilot("builtin", AutopilotOptions(mavlink="udp:127.0.0.1:14550", realtime=True))
    assert isinstance(ap, MavlinkControlledAutopilot) and ap.realtime and ap.port == 14550
    with pytest.raises(InputError, match="serves the built-in autopilot"):
        make_run_autopilot("px4", AutopilotOptions(mavlink="udp:127.0.0.1:14540"))
    with pytest.raises(InputError, match="--realtime"):
        make_run_autopilot("px4", AutopilotOptions(realtime=True))
