"""The built-in autopilot's MAVLink vehicle endpoint driven by raw pymavlink scripts (real UDP
on loopback, the real simulation loop in a background thread)."""

from __future__ import annotations

import math
import socket
import time

import pytest
from loopback_world import free_port
from pymavlink import mavutil

from tests.sitl.px4.sim_thread import SimThread
from vinecli.autopilot.base import RunStatus
from vinecli.autopilot.mavlink_vehicle import MavlinkControlledAutopilot, serve_mavlink
from vinecli.errors import InputError
from vinecli.mavlink import px4modes as M
from vinecli.specs.mission import MissionSpec

pytestmark = pytest.mark.timeout(120)

MISSION = MissionSpec.model_validate({
    "name": "mav-endpoint", "max_duration_s": 300.0,
    "phases": [{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "goto", "position_enu": [5.0, 0.0]},
               {"type": "sprayer", "flow_lps": 0.05}, {"type": "goto", "position_enu": [5.0, 5.0], "speed_mps": 2.0},
               {"type": "land"}],
})


@pytest.fixture
def vehicle(world):
    client_port = free_port(socket.SOCK_DGRAM)
    ap = MavlinkControlledAutopilot(url=f"udp:127.0.0.1:{client_port}", local_port=free_port(socket.SOCK_DGRAM))
    sim = SimThread(world, MISSION, ap).start()
    conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{client_port}", source_system=255, source_component=190,
                                      dialect="common")
    try:
        hb = conn.wait_heartbeat(timeout=10)
        assert hb is not None, "no heartbeat from the vehicle"
        yield conn, hb, sim, ap
    finally:
        sim.stop()
        try:
            sim.join(30)
        finally:
            conn.close()


def recv(conn, typ, timeout=3.0, cond=None):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = conn.recv_match(type=typ, blocking=True, timeout=0.2)
        if m is not None and (cond is None or cond(m)):
            return m
    raise AssertionError(f"no {typ} within {timeout} s")


def command(conn, cmd, *params):
    p = list(params) + [0.0] * (7 - len(params))
    conn.mav.command_long_send(1, 1, cmd, 0, *p)
    return recv(conn, "COMMAND_ACK", cond=lambda a: a.command == cmd)


def test_heartbeat_and_telemetry_look_like_px4(vehicle, world):
    conn, hb, _sim, _ap = vehicle
    assert (hb.get_srcSystem(), hb.get_srcComponent()) == (1, 1)
    assert hb.autopilot == M.MAV_AUTOPILOT_PX4 and hb.type == M.MAV_TYPE_QUADROTOR
    assert hb.base_mode & M.MODE_FLAG_CUSTOM and not hb.base_mode & M.MODE_FLAG_SAFETY_ARMED
    assert M.decode_custom_mode(hb.custom_mode) == (M.MAIN_AUTO, M.SUB_LOITER)
    ready = M.SENSOR_PREARM_CHECK | 32  # pre-arm checks pass and GPS healthy once the estimator has converged
    ss = recv(conn, "SYS_STATUS", timeout=20, cond=lambda s: s.onboard_control_sensors_health & ready == ready)
    assert ss.onboard_control_sensors_present & M.SENSORS_BASIC == M.SENSORS_BASIC
    gp = recv(conn, "GLOBAL_POSITION_INT")
    lat, lon, alt = world.origin.enu_to_geodetic_fast(*world.spawn_enu)
    assert abs(gp.lat - lat * 1e7) < 50 and abs(gp.lon - lon * 1e7) < 70  # estimate within ~5 m (units: degE7)
    assert abs(gp.alt - alt * 1000) < 200 and abs(gp.relative_alt) < 200
    assert recv(conn, "EXTENDED_SYS_STATE").landed_state == M.LANDED_ON_GROUND
    assert recv(conn, "GPS_RAW_INT").fix_type == 3
    q = recv(conn, "ATTITUDE_QUATERNION")
    assert math.isclose(q.q1 ** 2 + q.q2 ** 2 + q.q3 ** 2 + q.q4 ** 2, 1.0, abs_tol=1e-4)
    conn.mav.command_long_send(1, 1, M.CMD_REQUEST_MESSAGE, 0, 148, 0, 0, 0, 0, 0, 0)
    av = recv(conn, "AUTOPILOT_VERSION")
    assert av.capabilities & (4 | 8 | 8192) == 4 | 8 | 8192
    assert command(conn, M.CMD_REQUEST_PROTOCOL_VERSION, 1).result == 0
    pv = recv(conn, "UNKNOWN_300")  # not in pymavlink's common dialect: check the raw MAVLink 2 payload
    import struct

    assert struct.unpack("<HHH", bytes(pv.data)[10:10 + pv.data[1]].ljust(6, b"\0"))  # frame: 10-byte header == (200, 100, 200)
    conn.mav.command_long_send(1, 1, M.CMD_REQUEST_MESSAGE, 0, 242, 0, 0, 0, 0, 0, 0)
    home = recv(conn, "HOME_POSITION")
    assert abs(home.latitude - lat * 1e7) < 2


def test_mission_download_round_trip_and_upload(vehicle):
    conn, _hb, _sim, _ap = vehicle
    # the run's mission is pre-loaded: download it
    conn.mav.mission_request_list_send(1, 1, 0)
    n = recv(conn, "MISSION_COUNT").count
    items = []
    for seq in range(n):
        conn.mav.mission_request_int_send(1, 1, seq, 0)
        items.append(recv(conn, "MISSION_ITEM_INT", cond=lambda m, s=seq: m.seq == s))
    conn.mav.mission_ack_send(1, 1, 0, 0)
    cmds = [m.command for m in items]
    assert cmds == [M.CMD_NAV_TAKEOFF, M.CMD_NAV_WAYPOINT, M.CMD_DO_SET_ACTUATOR, M.CMD_DO_CHANGE_SPEED,
                    M.CMD_NAV_WAYPOINT, M.CMD_NAV_LAND]
    assert items[0].z == pytest.approx(3.0) and items[2].param1 == pytest.approx(0.5)  # 0.05 L/s of 0.1 max
    # upload it back, changed, and download again
    conn.mav.mission_count_send(1, 1, 2, 0)
    for seq in range(2):
        req = recv(conn, "MISSION_REQUEST_INT", cond=lambda m, s=seq: m.seq == s)
        src = items[0] if seq == 0 else items[5]
        conn.mav.mission_item_int_send(1, 1, req.seq, src.frame, src.command, int(seq == 0), 1, src.param1, src.param2,
                                       src.param3, src.param4, src.x, src.y, 7.5 if seq == 0 else 0.0, 0)
    assert recv(conn, "MISSION_ACK").type == M.MAV_MISSION_ACCEPTED
    conn.mav.mission_request_list_send(1, 1, 0)
    assert recv(conn, "MISSION_COUNT").count == 2
    conn.mav.mission_request_int_send(1, 1, 0, 0)
    assert recv(conn, "MISSION_ITEM_INT", cond=lambda m: m.seq == 0).z == pytest.approx(7.5)
    # an unsupported command in a mission is refused (ArduPilot's DO_SET_SERVO is fine, 42600 WINCH is not)
    conn.mav.mission_count_send(1, 1, 1, 0)
    recv(conn, "MISSION_REQUEST_INT")
    conn.mav.mission_item_int_send(1, 1, 0, 2, 42600, 0, 1, 0, 0, 0, 0, 0, 0, 0.0, 0)
    assert recv(conn, "MISSION_ACK").type == M.MAV_MISSION_UNSUPPORTED
    # geofence (type 1) is stored separately; clear it again
    conn.mav.mission_count_send(1, 1, 3, 1)
    for seq, (dn, de) in enumerate([(1, 1), (1, -1), (-1, 0)]):
        recv(conn, "MISSION_REQUEST_INT", cond=lambda m, s=seq: m.seq == s and m.mission_type == 1)
        conn.mav.mission_item_int_send(1, 1, seq, 0, M.CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, 0, 1, 3, 0, 0, 0,
                                       460705000 + dn * 1000, 111204000 + de * 1000, 0.0, 1)
    assert recv(conn, "MISSION_ACK", cond=lambda a: a.mission_type == 1).type == 0
    conn.mav.mission_request_list_send(1, 1, 1)
    assert recv(conn, "MISSION_COUNT", cond=lambda m: m.mission_type == 1).count == 3
    conn.mav.mission_request_list_send(1, 1, 0)
    assert recv(conn, "MISSION_COUNT", cond=lambda m: m.mission_type == 0).count == 2
    conn.mav.mission_clear_all_send(1, 1, 1)
    assert recv(conn, "MISSION_ACK", cond=lambda a: a.mission_type == 1).type == 0
    conn.mav.mission_request_list_send(1, 1, 1)
    assert recv(conn, "MISSION_COUNT", cond=lambda m: m.mission_type == 1).count == 0


def test_parameters_read_set_list(vehicle):
    conn, _hb, _sim, _ap = vehicle
    conn.mav.param_request_read_send(1, 1, b"MIS_TAKEOFF_ALT", -1)
    pv = recv(conn, "PARAM_VALUE", cond=lambda m: m.param_id == "MIS_TAKEOFF_ALT")
    assert pv.param_value == pytest.approx(3.0) and pv.param_type == 9  # from the run's takeoff phase
    conn.mav.param_set_send(1, 1, b"MIS_TAKEOFF_ALT", 4.5, 9)
    pv = recv(conn, "PARAM_VALUE", cond=lambda m: m.param_id == "MIS_TAKEOFF_ALT")
    assert pv.param_value == pytest.approx(4.5)
    conn.mav.param_request_list_send(1, 1)
    names = set()
    first = recv(conn, "PARAM_VALUE")
    names.add(first.param_id)
    while len(names) < first.param_count:
        names.add(recv(conn, "PARAM_VALUE").param_id)
    assert {"MIS_TAKEOFF_ALT", "RTL_RETURN_ALT", "MPC_XY_CRUISE", "GF_ACTION"} <= names


def test_unsupported_and_refused_commands(vehicle):
    conn, _hb, _sim, _ap = vehicle
    assert command(conn, 31000).result == M.MAV_RESULT_UNSUPPORTED  # MAV_CMD_USER_1
    assert command(conn, 2000).result == M.MAV_RESULT_UNSUPPORTED  # IMAGE_START_CAPTURE
    assert command(conn, M.CMD_NAV_TAKEOFF, *([math.nan] * 7)).result == M.MAV_RESULT_DENIED  # not armed
    assert command(conn, M.CMD_DO_SET_MODE, 1, M.MAIN_OFFBOARD, 0).result == M.MAV_RESULT_DENIED
    assert command(conn, M.CMD_SET_MESSAGE_INTERVAL, 245, 1e6).result == M.MAV_RESULT_ACCEPTED


def test_arm_takeoff_land_over_raw_mavlink(vehicle, world):
    conn, _hb, sim, ap = vehicle
    ready = M.SENSOR_PREARM_CHECK | 32
    recv(conn, "SYS_STATUS", timeout=20, cond=lambda s: s.onboard_control_sensors_health & ready == ready)
    assert command(conn, M.CMD_COMPONENT_ARM_DISARM, 1).result == 0
    recv(conn, "HEARTBEAT", cond=lambda h: h.base_mode & M.MODE_FLAG_SAFETY_ARMED)
    assert command(conn, M.CMD_NAV_TAKEOFF, *([math.nan] * 7)).result == 0  # MIS_TAKEOFF_ALT (3 m)
    recv(conn, "GLOBAL_POSITION_INT", timeout=30, cond=lambda g: g.relative_alt > 2700)
    recv(conn, "EXTENDED_SYS_STATE", cond=lambda e: e.landed_state == M.LANDED_IN_AIR)
    assert command(conn, M.CMD_DO_SET_ACTUATOR, 0.4, math.nan, math.nan, math.nan, math.nan, math.nan, 0).result == 0
    assert command(conn, M.CMD_NAV_LAND, *([math.nan] * 7)).result == 0
    recv(conn, "HEARTBEAT", timeout=30, cond=lambda h: not h.base_mode & M.MODE_FLAG_SAFETY_ARMED)
    res = sim.join(30)
    assert res.status is RunStatus.COMPLETED and "landed and disarmed" in res.detail
    ts = res.timeseries
    assert 2.7 < ts["pos_enu_z_m"].max() - world.spawn_enu[2] < 3.5
    assert ts["tank_flow_cmd_lps"].max() == pytest.approx(0.04)


def test_remote_address_needs_explicit_flag():
    with pytest.raises(InputError, match="not a loopback address"):
        serve_mavlink("udp:192.168.1.20:14540")
    with pytest.raises(InputError, match="bad MAVLink endpoint"):
        serve_mavlink("tcp:127.0.0.1")
    ap = serve_mavlink("udp:192.168.1.20:14540", allow_remote=True, realtime=True)
    assert ap.realtime and ap.host == "192.168.1.20"
