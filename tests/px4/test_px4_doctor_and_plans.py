"""`vinecli px4 doctor`, the run-autopilot factory, and mission -> MAVLink item conversion."""

from __future__ import annotations

import socket
import threading

import pytest
from typer.testing import CliRunner

from tests.px4.conftest import ORIGIN
from vinecli.cli.app import app
from vinecli.errors import InputError, SpecError
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.mission_items import PlanContext, degE7_to_enu, enu_to_degE7, items_to_phases, phases_to_items
from vinecli.sitl.options import make_run_autopilot
from vinecli.sitl.px4.doctor import px4_doctor
from vinecli.specs.mission import GotoPhase, HoldPhase, LandPhase, MissionSpec, SprayerPhase, TakeoffPhase

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
    assert (f"PX4_SIM_MODEL=none_iris PX4_PARAM_NAV_DLL_ACT=0 PX4_PARAM_COM_RC_IN_MODE=1 {exe} -d -i 3 "
            f"-w /tmp/px4-sitl-3 {etc}") in r.output.replace("\n", "")
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
    ap = make_run_autopilot("px4", px4_instance=4, px4_connect_timeout_s=5)
    assert isinstance(ap, Px4SitlAutopilot) and ap.port == 4564 and ap.connect_timeout_s == 5
    ap = make_run_autopilot("builtin", mavlink="udp:127.0.0.1:14550", realtime=True)
    assert isinstance(ap, MavlinkControlledAutopilot) and ap.realtime and ap.port == 14550
    with pytest.raises(InputError, match="serves the built-in autopilot"):
        make_run_autopilot("px4", mavlink="udp:127.0.0.1:14540")
    with pytest.raises(InputError, match="--realtime"):
        make_run_autopilot("px4", realtime=True)


# ---------------------------------------------------------------- mission -> items
def plan_ctx(**kw):
    return PlanContext(origin=ORIGIN, home_enu=(0.0, 0.0, 10.12), **kw)


def mission(*phases, **kw):
    return MissionSpec.model_validate({"name": "m", "phases": list(phases), **kw})


def test_open_loop_and_spray_until_empty_are_not_possible_with_px4():
    ol = {"type": "open_loop", "duration_s": 2, "rotor_speeds_rad_s": 500}
    with pytest.raises(SpecError, match="not possible with PX4"):
        phases_to_items(mission(ol), plan_ctx())
    sp = {"type": "spray", "flow_lps": 0.05, "until": "empty", "rows": [[[0, 0], [0, 5]]]}
    with pytest.raises(SpecError, match="not possible with PX4"):
        phases_to_items(mission(sp), plan_ctx(nozzle_max_flow_lps=0.1))
    with pytest.raises(SpecError, match="no tank"):
        phases_to_items(mission({"type": "sprayer", "flow_lps": 0.05}), plan_ctx())


def test_spray_rows_expand_to_waypoints_with_sprayer_on_along_rows_and_terrain_heights():
    def terrain(x: float, y: float) -> float:
        return 10.0 + 0.1 * y  # 10 % slope northwards

    m = mission({"type": "takeoff", "altitude_agl_m": 3},
                {"type": "spray", "height_agl_m": 2.0, "speed_mps": 1.2, "flow_lps": 0.03,
                 "rows": [[[1, 0], [1, 10]], [[3, 0], [3, 10]]]},
                {"type": "land"},
                geofence={"polygon_enu": [[-20, -20], [20, -20], [20, 20]], "action": "rtl", "max_altitude_agl_m": 30})
    plan = phases_to_items(m, plan_ctx(terrain_height=terrain, nozzle_max_flow_lps=0.1))
    cmds = [it.command for it in plan.items]
    assert cmds == [22, 178, 187, 16, 187, 16, 187, 16, 187, 16, 187, 21]
    acts = [it.param1 for it in plan.items if it.command == 187]
    assert acts == pytest.approx([0.0, 0.3, 0.0, 0.3, 0.0])  # off, on along row 1, off, on along row 2 (reversed), off
    wps = [it for it in plan.items if it.command == 16]
    xy = [degE7_to_enu(ORIGIN, it.x, it.y) for it in wps]
    assert xy == [pytest.approx(p, abs=0.02) for p in [(1, 0), (1, 10), (3, 10), (3, 0)]]  # boustrophedon
    # 2 m above the terrain under each waypoint, expressed above home (home ground z = 10.0)
    assert [it.z for it in wps] == pytest.approx([2.0, 3.0, 3.0, 2.0])
    assert all(it.frame == M.MAV_FRAME_GLOBAL_RELATIVE_ALT for it in wps)
    assert plan.items[1].param2 == pytest.approx(1.2)
    assert plan.params["MIS_TAKEOFF_ALT"] == 3.0 and plan.params["GF_ACTION"] == 3 and plan.params["GF_MAX_VER_DIST"] == 30
    assert [f.command for f in plan.fence] == [5001] * 3 and all(f.param1 == 3 and f.mission_type == 1 for f in plan.fence)
    assert plan.phase_of_item[0] == 0 and plan.phase_of_item[-1] == 2


def test_items_round_trip_to_phases():
    m = mission({"type": "takeoff", "altitude_agl_m": 4}, {"type": "goto", "position_enu": [5, 6], "yaw_deg": 0, "speed_mps": 3},
                {"type": "hold", "duration_s": 2}, {"type": "sprayer", "flow_lps": 0.05}, {"type": "land"})
    plan = phases_to_items(m, plan_ctx(nozzle_max_flow_lps=0.1))
    yaw_item = next(it for it in plan.items if it.command == 16)
    assert yaw_item.param4 == pytest.approx(90.0)  # ENU yaw 0 (east) = NED heading 90°
    phases, src = items_to_phases(plan.items, ORIGIN, ORIGIN.alt + 10.12, 0.1)
    kinds = [type(p) for p in phases]
    assert kinds == [TakeoffPhase, GotoPhase, GotoPhase, HoldPhase, SprayerPhase, GotoPhase, LandPhase]
    goto = phases[1]
    assert goto.position_enu == pytest.approx((5, 6), abs=0.02) and goto.speed_mps == 3 and goto.yaw_deg == pytest.approx(0.0)
    assert phases[3].duration_s == 2 and phases[4].flow_lps == pytest.approx(0.05)
    assert len(src) == len(phases) and src[0] == 0
    lat, lon = enu_to_degE7(ORIGIN, 100.0, -50.0)
    assert degE7_to_enu(ORIGIN, lat, lon) == pytest.approx((100.0, -50.0), abs=0.02)
