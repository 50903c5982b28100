"""The vehicle side of ``--mavlink URL``: bind checks and links that serve several ground stations.

URL schemes, as pymavlink's ``mavlink_connection`` means them (seen from vinecli):

* ``udpin:HOST:PORT``  - bind HOST:PORT and answer whoever talks to it;
* ``udpout:HOST:PORT`` - send to HOST:PORT (a GCS listening there, e.g. MAVSDK/pymavlink with
  ``udpin``) from a local port (``local_port``; 0 = any);
* ``udp:HOST:PORT``    - vinecli's PX4-like default: as ``udpout`` from local port 14580+instance;
* ``tcpin:HOST:PORT``  - listen on TCP HOST:PORT and accept ground stations (QGC "TCP link");
* ``tcp:HOST:PORT``    - connect to a TCP server at HOST:PORT (retried until it answers).

Telemetry goes to every ground station that has sent at least one *valid* MAVLink message (a
frame with a good checksum) -- up to ``max_peers`` at a time; a UDP peer silent for
``peer_timeout_s`` frees its slot -- plus the fixed ``udpout``/``udp`` target. Bytes that do not
parse never redirect telemetry. Each peer has its own stateful parser.

Addresses are resolved (IPv4) and checked as IPs: loopback (127.0.0.0/8) unless ``allow_remote``.
"""

from __future__ import annotations

import contextlib
import ipaddress
import logging
import socket
import threading
import time
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2

from vinecli.errors import InputError
from vinecli.mavlink.link import Link, bound_udp_socket, listening_tcp_socket

log = logging.getLogger(__name__)

SCHEMES = ("udp", "udpin", "udpout", "tcp", "tcpin")


def resolve_ipv4(host: str) -> str:
    """The IPv4 address of ``host`` (a literal or a name); InputError if it does not resolve."""
    try:
        return str(ipaddress.IPv4Address(host))
    except ValueError:
        pass
    try:
        infos = socket.getaddrinfo(host, None, socket.AF_INET, socket.SOCK_DGRAM)
    except (OSError, UnicodeError) as exc:
        raise InputError(f"MAVLink address {host!r} does not resolve to an IPv4 address ({exc})") from None
    return str(infos[0][4][0])


def checked_address(host: str, allow_remote: bool, what: str = "--mavlink") -> str:
    """``host`` resolved to an IP; InputError unless it is loopback or ``allow_remote``."""
    ip = resolve_ipv4(host)
    if not ipaddress.IPv4Address(ip).is_loopback and not allow_remote:
        raise InputError(f"{what}: {host} ({ip}) is not a loopback address; add --mavlink-allow-remote to expose the vehicle")
    return ip


class _Peer:
    """One ground station: its own parser, last time heard."""

    def __init__(self, src_system: int, src_component: int) -> None:
        self.parser = mavlink2.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
        self.parser.robust_parsing = True
        self.last_valid = 0.0

    def parse(self, data: bytes) -> list[Any]:
        msgs = self.parser.parse_buffer(data) or []
        return [m for m in msgs if m.get_type() != "BAD_DATA"]


class MultiPeerUdpLink(Link):
    """UDP bound to ``bind``; sends to ``target`` (if any) and to every peer that sent valid MAVLink."""

    def __init__(self, bind: tuple[str, int], target: tuple[str, int] | None = None, *, src_system: int = 1,
                 src_component: int = 1, max_peers: int = 4, peer_timeout_s: float = 10.0) -> None:
        super().__init__(src_system, src_component, name=f"udp-multi-{bind[1]}")
        self._sock = bound_udp_socket(bind, InputError)
        self.local = self._sock.getsockname()
        self.target = target
        self.max_peers, self.peer_timeout_s = max_peers, peer_timeout_s
        self._src = (src_system, src_component)
        self.peers: dict[tuple[str, int], _Peer] = {}
        self._candidates: dict[tuple[str, int], _Peer] = {}  # heard from, nothing valid yet
        self._peers_lock = threading.Lock()
        self._start_reader()

    @property
    def remote(self) -> tuple[str, int] | None:
        """The fixed target, else the most recent valid peer (for messages)."""
        if self.target is not None:
            return self.target
        with self._peers_lock:
            return next(reversed(self.peers), None) if self.peers else None

    def _reader(self) -> None:
        while not self._stop.is_set():
            try:
                data, addr = self._sock.recvfrom(65536)
            except TimeoutError:
                continue
            except OSError:
                break
            self._from(data, (addr[0], addr[1]))

    def _from(self, data: bytes, addr: tuple[str, int]) -> None:
        now = time.monotonic()
        with self._peers_lock:
            self._expire(now)
            peer = self.peers.get(addr) or self._candidates.get(addr)
            if peer is None:
                if len(self._candidates) >= 4 * self.max_peers:
                    self._candidates.pop(next(iter(self._candidates)))
                peer = self._candidates[addr] = _Peer(*self._src)
        msgs = peer.parse(data)
        if not msgs:
            return
        with self._peers_lock:
            peer.last_valid = now
            if addr not in self.peers:
                if len(self.peers) >= self.max_peers:
                    log.warning("MAVLink: %s:%d ignored (%d ground stations already)", addr[0], addr[1], self.max_peers)
                    return
                self._candidates.pop(addr, None)
                self.peers[addr] = peer
                log.info("MAVLink: ground station %s:%d", addr[0], addr[1])
        self._deliver(msgs)

    def _expire(self, now: float) -> None:
        for a in [a for a, p in self.peers.items() if now - p.last_valid > self.peer_timeout_s]:
            del self.peers[a]

    def _send_bytes(self, buf: bytes) -> None:
        with self._peers_lock:
            dests = list(self.peers)
        if self.target is not None and self.target not in dests:
            dests.append(self.target)
        for d in dests:
            try:
                self._sock.sendto(buf, d)
            except OSError as exc:  # e.g. ECONNREFUSED from an earlier ICMP: UDP is best effort
                log.debug("UDP send to %s failed: %s", d, exc)

    def _close_sockets(self) -> None:
        self._sock.close()


class TcpServerGcsLink(Link):
    """Listen on TCP ``bind``; accept up to ``max_peers`` ground stations; telemetry to each."""

    def __init__(self, bind: tuple[str, int], *, src_system: int = 1, src_component: int = 1, max_peers: int = 4) -> None:
        super().__init__(src_system, src_component, name=f"tcp-gcs-{bind[1]}")
        self._srv = listening_tcp_socket(bind, max_peers, InputError)
        self._srv.settimeout(0.2)
        self.local = self._srv.getsockname()
        self.max_peers = max_peers
        self._src = (src_system, src_component)
        self.conns: list[socket.socket] = []
        self._conns_lock = threading.Lock()
        self._start_reader()

    def _reader(self) -> None:  # the accept loop; one reader thread per connection
        while not self._stop.is_set():
            try:
                conn, addr = self._srv.accept()
            except TimeoutError:
                continue
            except OSError:
                break
            with self._conns_lock:
                if len(self.conns) >= self.max_peers:
                    conn.close()
                    continue
                self.conns.append(conn)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            conn.settimeout(0.2)
            threading.Thread(target=self._serve, args=(conn,), name=f"tcp-gcs-{addr[1]}", daemon=True).start()

    def _serve(self, conn: socket.socket) -> None:
        self._read_stream(conn, _Peer(*self._src).parser, mark_closed=False)
        with self._conns_lock:
            if conn in self.conns:
                self.conns.remove(conn)
        with contextlib.suppress(OSError):
            conn.close()

    def _send_bytes(self, buf: bytes) -> None:
        with self._conns_lock:
            conns = list(self.conns)
        for c in conns:
            try:
                c.sendall(buf)
            except OSError:
                with self._conns_lock, contextlib.suppress(ValueError):
                    self.conns.remove(c)

    def _close_sockets(self) -> None:
        with self._conns_lock:
            conns, self.conns = self.conns, []
        for s in (*conns, self._srv):
            with contextlib.suppress(OSError):
                s.close()


class TcpClientGcsLink(Link):
    """Connect to a TCP server at ``remote`` in the background (retried every 0.5 s, and again after a drop)."""

    def __init__(self, remote: tuple[str, int], *, src_system: int = 1, src_component: int = 1) -> None:
        super().__init__(src_system, src_component, name=f"tcp-out-{remote[1]}")
        self.remote = remote
        self._sock: socket.socket | None = None
        self._start_reader()

    def _reader(self) -> None:
        while not self._stop.is_set():
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            try:
                s.settimeout(1.0)
                s.connect(self.remote)
            except OSError:
                s.close()
                self._stop.wait(0.5)
                continue
            s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            s.settimeout(0.2)
            self._sock = s
            self._read_stream(s, _Peer(*self._tx_ids()).parser, mark_closed=False)
            self._sock = None
            with contextlib.suppress(OSError):
                s.close()

    def _tx_ids(self) -> tuple[int, int]:
        return self._tx.srcSystem, self._tx.srcComponent

    def _send_bytes(self, buf: bytes) -> None:
        s = self._sock
        if s is None:
            return  # not connected (yet): telemetry is dropped, as over UDP with nobody listening
        try:
            s.sendall(buf)
        except OSError as exc:
            log.debug("TCP send to %s failed: %s", self.remote, exc)

    def _close_sockets(self) -> None:
        s = self._sock
        if s is not None:
            with contextlib.suppress(OSError):
                s.close()


def open_vehicle_link(scheme: str, ip: str, port: int, *, local_port: int | None, instance: int = 0,
                      src_system: int = 1, src_component: int = 1) -> Link:
    """The vehicle's link for ``--mavlink SCHEME:HOST:PORT`` (module docstring), opened on ``ip``: HOST as
    :func:`checked_address` returned it. The caller checks the URL (that one place gives the error
    messages): ``ip`` loopback unless remote is allowed, ``local_port`` only with udp:/udpout:."""
    ids = {"src_system": src_system, "src_component": src_component}
    local_any = "0.0.0.0" if not ipaddress.IPv4Address(ip).is_loopback else "127.0.0.1"
    if scheme == "udpin":
        return MultiPeerUdpLink((ip, port), None, **ids)
    if scheme in ("udp", "udpout"):
        default = 14580 + instance if scheme == "udp" else 0
        return MultiPeerUdpLink((local_any, default if local_port is None else local_port), (ip, port), **ids)
    if scheme == "tcpin":
        return TcpServerGcsLink((ip, port), **ids)
    return TcpClientGcsLink((ip, port), **ids)


__all__ = ["MultiPeerUdpLink", "SCHEMES", "TcpClientGcsLink", "TcpServerGcsLink", "checked_address",
           "open_vehicle_link", "resolve_ipv4"]
