"""``--mavlink`` transports: the address checked as an IP, every scheme as pymavlink means it,
vinecli's own port, telemetry to every ground station that sent valid MAVLink (real sockets)."""

from __future__ import annotations

import socket
import time

import pytest
from loopback_world import free_port
from pymavlink import mavutil

from tests.sitl.px4.sim_thread import SimThread
from vinecli.autopilot.mavlink_vehicle import MavlinkControlledAutopilot, serve_mavlink
from vinecli.errors import InputError
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.gcs_link import MultiPeerUdpLink, checked_address
from vinecli.mavlink.link import is_loopback
from vinecli.specs.mission import MissionSpec

pytestmark = pytest.mark.timeout(120)

MISSION = MissionSpec.model_validate({"name": "transports", "max_duration_s": 120.0,
                                      "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "land"}]})


def gcs(url: str) -> mavutil.mavfile:
    return mavutil.mavlink_connection(url, source_system=255, source_component=190, dialect="common")


def heartbeat(conn: mavutil.mavfile) -> None:
    conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, M.MAV_STATE_ACTIVE)


def vehicle_heartbeat(conn: mavutil.mavfile, timeout: float = 5.0, ping: bool = False) -> object | None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if ping:
            heartbeat(conn)
        m = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.2)
        if m is not None and m.get_srcSystem() == 1:
            return m
    return None


def test_address_is_resolved_and_checked_as_an_ip():
    with pytest.raises(InputError):  # prefix-matched before; it is a DNS name, not 127.0.0.1
        checked_address("127.0.0.1.example.org", allow_remote=False)
    assert not is_loopback("127.0.0.1.example.org")
    assert checked_address("localhost", False) == "127.0.0.1" and checked_address("127.0.0.5", False) == "127.0.0.5"
    with pytest.raises(InputError, match="not a loopback address"):
        checked_address("192.168.1.20", allow_remote=False)
    with pytest.raises(InputError):
        serve_mavlink("udp:127.0.0.1.example.org:14540")


def test_garbage_does_not_steal_telemetry_and_every_valid_gcs_gets_it():
    link = MultiPeerUdpLink(("127.0.0.1", 0), None, max_peers=2)
    port = link.local[1]
    a, b, c, junk = (socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(4))
    try:
        for s in (a, b, c, junk):
            s.bind(("127.0.0.1", 0))
            s.settimeout(1.0)
        sender = mavutil.mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
        hb = sender.heartbeat_encode(6, 8, 0, 0, 4).pack(sender)
        a.sendto(hb, ("127.0.0.1", port))
        time.sleep(0.2)
        junk.sendto(b"\xfd\x09garbage-not-mavlink" * 3, ("127.0.0.1", port))
        b.sendto(hb, ("127.0.0.1", port))
        time.sleep(0.2)
        c.sendto(hb, ("127.0.0.1", port))  # a third GCS: over the limit of 2
        time.sleep(0.2)
        link.send(link.mav.heartbeat_encode(2, 12, 0, 0, 3))
        assert a.recv(1024) and b.recv(1024)  # both valid ground stations get telemetry
        junk.settimeout(0.3)
        c.settimeout(0.3)
        with pytest.raises(TimeoutError):
            junk.recv(1024)  # garbage never redirects telemetry
        with pytest.raises(TimeoutError):
            c.recv(1024)
        assert set(link.peers) == {a.getsockname(), b.getsockname()}
    finally:
        link.close()
        for s in (a, b, c, junk):
            s.close()


@pytest.mark.parametrize("scheme", ["udpin", "tcpin", "tcp", "udpout"])
def test_each_scheme_serves_a_pymavlink_client(world, scheme):
    tcp = scheme.startswith("tcp")
    port = free_port(socket.SOCK_STREAM if tcp else socket.SOCK_DGRAM)
    local_port = free_port(socket.SOCK_DGRAM) if scheme == "udpout" else None
    client_url = {"udpin": f"udpout:127.0.0.1:{port}", "tcpin": f"tcp:127.0.0.1:{port}",
                  "tcp": f"tcpin:127.0.0.1:{port}", "udpout": f"udpin:127.0.0.1:{port}"}[scheme]
    conn = gcs(client_url) if scheme in ("tcp", "udpout") else None  # listeners first
    ap = MavlinkControlledAutopilot(url=f"{scheme}:127.0.0.1:{port}", local_port=local_port)
    sim = SimThread(world, MISSION, ap).start()
    try:
        time.sleep(0.3)
        if conn is None:
            conn = gcs(client_url)
        hb = vehicle_heartbeat(conn, timeout=8.0, ping=scheme == "udpin")
        assert hb is not None and hb.autopilot == M.MAV_AUTOPILOT_PX4, scheme
        kind = type(ap.link).__name__
        assert kind == {"udpin": "MultiPeerUdpLink", "udpout": "MultiPeerUdpLink", "tcpin": "TcpServerGcsLink",
                        "tcp": "TcpClientGcsLink"}[scheme]
        if scheme == "udpout":  # vinecli's own port is the one asked for
            assert ap.link.local[1] == local_port
    finally:
        sim.stop()
        try:
            sim.join(30)
        finally:
            if conn is not None:
                conn.close()


def test_port_option_only_where_it_means_something():
    for url in ("udpin:127.0.0.1:14600", "tcpin:127.0.0.1:5760", "tcp:127.0.0.1:5760"):
        with pytest.raises(InputError, match="--mavlink-port"):
            serve_mavlink(url, local_port=14601)
