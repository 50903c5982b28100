"""Delivery of vinecli's MAVLink bytes into a firmware's socket (``vinecli/sitl/delivery.py``), on real loopback
TCP connections: the kernel's count of what the far end received, and the wait before a lockstep answer."""

from __future__ import annotations

import socket
import sys
from collections.abc import Iterator

import pytest

from vinecli.sitl.delivery import PeerReceipt
from vinecli.sitl.polled_link import PolledTcpLink

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="sock_diag is Linux's")


@pytest.fixture
def server() -> Iterator[socket.socket]:
    srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    yield srv
    srv.close()


def test_the_peer_count_is_what_reached_its_socket_read_or_not(server):
    client = socket.create_connection(server.getsockname())
    peer, _ = server.accept()
    receipt = PeerReceipt()
    try:
        assert receipt.received(client) == 0
        client.sendall(b"x" * 1234)
        client.sendall(b"y" * 10)
        assert receipt.received(client) == 1244  # queued at the peer, not read yet
        assert peer.recv(4096).startswith(b"x")
        assert receipt.received(client) == 1244  # received, not "still queued": reading changes nothing
        assert receipt.received(peer) == 0  # the other direction: nothing sent to the client
    finally:
        receipt.close()
        client.close()
        peer.close()


def test_the_link_waits_until_the_firmware_socket_holds_every_byte(server):
    link = PolledTcpLink(*server.getsockname())
    assert link.try_connect()
    peer, _ = server.accept()
    try:
        assert link.wait_received(1.0) is True  # nothing sent
        link.send(link.mav.heartbeat_encode(6, 8, 0, 0, 4))
        link.send(link.mav.timesync_encode(0, 5))
        assert link.wait_received(1.0) in (True, False)  # there, at once or after a wait
        assert link.receipt.received(link.sock) == link.tx_bytes
        got = b""
        while len(got) < link.tx_bytes:
            got += peer.recv(4096)
        assert len(got) == link.tx_bytes  # the count is the bytes on the wire
    finally:
        link.close()
        peer.close()


def test_bytes_the_firmware_cannot_take_are_reported_not_waited_for_forever(server):
    """A peer whose receive buffer is full (it does not read): the bytes stay in vinecli's send queue, the
    wait gives up after its wall-time limit and says so (None): that answer would carry no guarantee."""
    server.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 2048)  # inherited by the accepted socket
    link = PolledTcpLink(*server.getsockname())
    assert link.try_connect()
    peer, _ = server.accept()
    try:
        payload = link.mav.param_set_encode(1, 1, b"SIM_BATT_VOLTAGE", 16.4, 9)
        for _ in range(400):  # ~14 kB: more than the peer's buffer, less than vinecli's send buffer
            link.send(payload)
        assert link.receipt.received(link.sock) < link.tx_bytes
        assert link.wait_received(0.2) is None
        while link.receipt.received(link.sock) < link.tx_bytes:  # the firmware reads: everything arrives
            peer.recv(65536)
        assert link.wait_received(1.0) is True
    finally:
        link.close()
        peer.close()
