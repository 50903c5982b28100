"""Field-level tests of the simulator link: what Px4SitlAutopilot sends for a known state, and
how it maps PX4's actuator outputs. A raw pymavlink TCP peer plays PX4 (real loopback socket)."""

from __future__ import annotations

import math
import threading
import time

import pytest
from loopback_world import ORIGIN

from vinecli.autopilot.base import AutopilotContext
from vinecli.errors import AutopilotError, InputError
from vinecli.frames import quat_from_euler
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.link import TcpClientLink
from vinecli.sitl.px4.backend import Px4SitlAutopilot
from vinecli.sitl.px4.process import px4_start_command
from vinecli.specs.mission import MissionSpec
from vinecli.types import BaroSample, GnssSample, ImuSample, MagSample, Observation, RigidState
from vinecli.vehicle import load_vehicle

pytestmark = pytest.mark.timeout(60)
DT = 4000


def ctx_for(vehicle_name: str = "x500-sprayer") -> AutopilotContext:
    v = load_vehicle(vehicle_name)
    m = MissionSpec.model_validate({"name": "p", "phases": [{"type": "hold", "duration_s": 1}]})
    return AutopilotContext(mission=m, vehicle=v, origin=ORIGIN, home_enu=(0.0, 0.0, 0.12), physics_dt_us=DT)


def connect_peer(port: int) -> TcpClientLink:
    peer = TcpClientLink("127.0.0.1", port, src_system=1, src_component=1)
    assert peer.connect(5.0)
    peer.send(peer.mav.heartbeat_encode(M.MAV_TYPE_QUADROTOR, M.MAV_AUTOPILOT_PX4, 1, 0, 3))
    peer.send(peer.mav.command_long_encode(0, 0, M.CMD_SET_MESSAGE_INTERVAL, 0, 115, 5000, 0, 0, 0, 0, 0))
    return peer


def start(ports: dict[str, int], **kw: object) -> tuple[Px4SitlAutopilot, TcpClientLink]:
    ap = Px4SitlAutopilot(port=ports["sim"], mission=False, connect_timeout_s=5, **kw)  # type: ignore[arg-type]
    box: dict[str, TcpClientLink] = {}

    def run_peer() -> None:
        time.sleep(0.05)
        box["peer"] = connect_peer(ports["sim"])

    th = threading.Thread(target=run_peer)
    th.start()
    ap.reset(ctx_for())
    th.join()
    return ap, box["peer"]


def obs_at(t_us: int, *, gnss: bool = True) -> Observation:
    q = quat_from_euler(math.radians(30.0), 0.0, math.radians(90.0))  # FLU roll 30°, ENU yaw 90° (north)
    truth = RigidState(t_us, (1.0, 2.0, 3.0), q, (0.5, -1.0, 0.2), (0.1, -0.2, 0.3), (0.0, 0.0, 0.0), False)
    imu = ImuSample(t_us, (0.1, 0.2, 9.7), (0.01, -0.02, 0.03))
    baro = BaroSample(t_us, 98000.0, 15.0, 213.0)
    mag = MagSample(t_us, (0.2, -0.05, -0.4))
    g = GnssSample(t_us, 46.07, 11.12, 213.5, (3.0, 4.0, 0.5), 3, 11, 0.7, 1.2) if gnss else None
    return Observation(t_us, truth, imu, baro, mag, g)


def by_type(peer: TcpClientLink, timeout: float = 2.0) -> dict[str, list[object]]:
    out: dict[str, list[object]] = {}
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = peer.recv(0.1)
        if m is None:
            if out:
                break
            continue
        out.setdefault(m.get_type(), []).append(m)
    return out


def test_hil_messages_carry_px4_units_and_frames(ports):
    ap, peer = start(ports)
    try:
        ap.step(obs_at(0))
        got = by_type(peer)
        s = got["HIL_SENSOR"][0]
        assert s.time_usec == DT  # sim time + one step: never 0
        assert (s.xacc, s.yacc, s.zacc) == pytest.approx((0.1, -0.2, -9.7), abs=1e-5)  # FLU -> FRD
        assert (s.xgyro, s.ygyro, s.zgyro) == pytest.approx((0.01, 0.02, -0.03), abs=1e-6)
        assert (s.xmag, s.ymag, s.zmag) == pytest.approx((0.2, 0.05, 0.4), abs=1e-6)  # gauss, FRD
        assert s.abs_pressure == pytest.approx(980.0)  # Pa -> hPa
        assert s.temperature == pytest.approx(15.0) and s.pressure_alt == pytest.approx(213.0)
        assert s.fields_updated == 7167 and s.id == 0
        g = got["HIL_GPS"][0]
        assert (g.lat, g.lon, g.alt) == (460700000, 111200000, 213500)  # degE7, mm
        assert (g.eph, g.epv, g.fix_type, g.satellites_visible) == (70, 120, 3, 11)  # cm
        assert (g.vn, g.ve, g.vd) == (400, 300, -50)  # cm/s NED from ENU (3, 4, 0.5)
        assert g.vel == 500 and g.cog == round(math.degrees(math.atan2(3, 4)) * 100)
        assert g.time_usec > 1_600_000_000_000_000  # UNIX epoch µs
        st = got["HIL_STATE_QUATERNION"][0]
        # ENU yaw 90° (facing north), roll +30° about forward (right side down) -> NED heading 0°, FRD roll +30°
        from vinecli.frames import quat_to_euler, wxyz_to_xyzw

        r, p, y = quat_to_euler(wxyz_to_xyzw(tuple(st.attitude_quaternion)))
        assert (math.degrees(r), math.degrees(p), math.degrees(y)) == pytest.approx((30.0, 0.0, 0.0), abs=1e-3)
        assert (st.rollspeed, st.pitchspeed, st.yawspeed) == pytest.approx((0.1, 0.2, -0.3), abs=1e-6)
        assert (st.vx, st.vy, st.vz) == (-100, 50, -20)  # NED cm/s of ENU (0.5, -1, 0.2)
        lat, lon, alt = ORIGIN.enu_to_geodetic_fast(1.0, 2.0, 3.0)
        assert (st.lat, st.lon, st.alt) == (round(lat * 1e7), round(lon * 1e7), round(alt * 1000))
        # a step without a new GNSS sample sends no HIL_GPS, and time advances by exactly one step
        ap.lockstep = True
        ap.step_timeout_s = 0.01
        ap.step(obs_at(DT, gnss=False))
        got2 = by_type(peer)
        assert "HIL_GPS" not in got2 and got2["HIL_SENSOR"][0].time_usec == 2 * DT
        # no new mag/baro sample at this step: only accel|gyro are flagged, the values are held
        held = obs_at(DT, gnss=False)
        ap.step(Observation(2 * DT, held.truth, held.imu, None, None, None))
        s3 = by_type(peer)["HIL_SENSOR"][0]
        assert s3.fields_updated == 63 and s3.xmag == pytest.approx(0.2) and s3.abs_pressure == pytest.approx(980.0)
        assert ap.stalls == 2  # nobody answered
    finally:
        peer.close()
        ap.close()


def test_actuator_outputs_map_to_rotor_speeds_and_sprayer(ports):
    ap, peer = start(ports, step_timeout_s=1.0)
    v = load_vehicle("x500-sprayer")
    try:
        ap.lockstep = True
        u = [0.0] * 16
        u[0], u[1], u[2], u[3], u[8] = 0.5, 0.25, 1.0, 1.7, 0.3
        t = DT

        def answer(mode: int, t_reply: int) -> None:
            m = peer.recv_match("HIL_SENSOR", 2.0)
            assert m is not None and m.time_usec == t_reply
            peer.send(peer.mav.hil_actuator_controls_encode(m.time_usec, u, mode, 1))

        th = threading.Thread(target=answer, args=(129, t))
        th.start()
        cmd = ap.step(obs_at(0, gnss=False))
        th.join()
        span = v.motor.w_max - v.px4.w_min_rad_s
        assert cmd.armed
        assert cmd.rotor_speed_cmd == pytest.approx((100 + 0.5 * span, 100 + 0.25 * span, 1300.0, 1300.0))  # clamp u <= 1
        assert cmd.spray_flow_lps == pytest.approx(0.3 * 0.1)
        assert ap.stalls == 0
        th = threading.Thread(target=answer, args=(1, 2 * DT))  # disarmed: motors off even with non-zero outputs
        th.start()
        cmd = ap.step(obs_at(DT, gnss=False))
        th.join()
        assert not cmd.armed and cmd.rotor_speed_cmd == (0.0,) * 4 and cmd.spray_flow_lps == 0.0
    finally:
        peer.close()
        ap.close()


def test_stalls_reuse_last_controls_then_fail(ports):
    ap, peer = start(ports, step_timeout_s=0.02, max_stalls=3)
    try:
        ap.lockstep = True
        ap.armed = True
        ap.controls = (0.5,) * 16
        cmd = ap.step(obs_at(0, gnss=False))  # no answer: last controls reused
        assert ap.stalls == 1 and cmd.armed and cmd.rotor_speed_cmd[0] == pytest.approx(100 + 0.5 * 1200)
        assert ap.status().extra["px4_stalls"] == 1.0
        ap.step(obs_at(DT, gnss=False))
        with pytest.raises(AutopilotError, match="stopped answering .*3 consecutive steps"):
            ap.step(obs_at(2 * DT, gnss=False))
    finally:
        peer.close()
        ap.close()


def test_boot_phase_is_paced_at_wall_clock(ports):
    ap, peer = start(ports)
    try:
        t0 = time.monotonic()
        for k in range(50):
            cmd = ap.step(obs_at(k * DT, gnss=False))
            assert not cmd.armed and cmd.rotor_speed_cmd == (0.0,) * 4
        assert time.monotonic() - t0 >= 0.19  # 50 steps of 4 ms
        assert not ap.lockstep
        peer.send(peer.mav.hil_actuator_controls_encode(50 * DT, [0.0] * 16, 1, 1))
        time.sleep(0.05)
        ap.step(obs_at(50 * DT, gnss=False))
        assert ap.lockstep
        assert any(e.kind == "px4" and "lockstep" in e.message for e in ap.drain_events())
        assert ap.requested_state_interval_us == 5000  # PX4's SET_MESSAGE_INTERVAL(115, 5000) was read
    finally:
        peer.close()
        ap.close()


def test_peer_closing_the_connection_is_an_error(ports):
    ap, peer = start(ports)
    try:
        peer.close()
        time.sleep(0.3)
        with pytest.raises(AutopilotError, match="closed the simulator connection"):
            ap.step(obs_at(0))
    finally:
        ap.close()


def test_options_are_validated():
    with pytest.raises(InputError, match="non-loopback"):
        Px4SitlAutopilot(host="0.0.0.0")
    with pytest.raises(InputError, match="unknown option"):
        Px4SitlAutopilot(speed=3)
    ap = Px4SitlAutopilot(instance=2)
    assert (ap.port, ap.api_port, ap.px4_api_port) == (4562, 14542, 14582)


def test_start_command_is_exact():
    assert px4_start_command(1) == (
        "mkdir -p /tmp/px4-sitl-1/rc && printf '%s\\n' 'param set NAV_DLL_ACT 0' 'param set COM_RC_IN_MODE 1' "
        "'param set IMU_GYRO_CAL_EN 0' > /tmp/px4-sitl-1/rc/px4-rc.params && PATH=/tmp/px4-sitl-1/rc:$PATH "
        "PX4_SIM_MODEL=none_iris px4 -d -i 1 -w /tmp/px4-sitl-1/rootfs build/px4_sitl_default/etc")
    cmd = px4_start_command(0, host="10.0.0.5", px4_bin="/opt/PX4-Autopilot/build/px4_sitl_default/bin/px4")
    assert "PX4_SIM_HOST_ADDR=10.0.0.5" in cmd
    assert cmd.endswith("/opt/PX4-Autopilot/build/px4_sitl_default/bin/px4 -d -i 0 -w /tmp/px4-sitl-0/rootfs "
                        "/opt/PX4-Autopilot/build/px4_sitl_default/etc")


def test_start_command_gives_px4_its_boot_parameters(tmp_path):
    """The hint runs in a real shell: PX4's rcS would find px4-rc.params on PATH with the parameters PX4 v1.15
    needs at boot (it ignores PX4_PARAM_* in the environment). A stand-in px4 prints what rcS would source."""
    import subprocess

    fake = tmp_path / "bin" / "px4"
    fake.parent.mkdir()
    fake.write_text('#!/bin/sh\nfor d in $(echo "$PATH" | tr : " "); do\n'  # rcS: '. px4-rc.params' (PATH search)
                    '  if [ -f "$d/px4-rc.params" ]; then cat "$d/px4-rc.params"; break; fi\ndone\n'
                    'echo "model=$PX4_SIM_MODEL args=$*"\n')
    fake.chmod(0o755)
    cmd = px4_start_command(3, px4_bin=str(fake), workdir=str(tmp_path / "wd"))
    out = subprocess.run(["/bin/sh", "-c", cmd], capture_output=True, text=True, check=True).stdout.splitlines()
    assert out[:3] == ["param set NAV_DLL_ACT 0", "param set COM_RC_IN_MODE 1", "param set IMU_GYRO_CAL_EN 0"]
    assert out[3].startswith("model=none_iris args=-d -i 3 -w " + str(tmp_path / "wd" / "rootfs"))


def test_without_hil_state_only_sensors_and_gps_are_sent(ports):
    ap, peer = start(ports, hil_state=False)
    try:
        ap.step(obs_at(0))
        got = by_type(peer)
        assert set(got) == {"HIL_SENSOR", "HIL_GPS"}
    finally:
        peer.close()
        ap.close()
