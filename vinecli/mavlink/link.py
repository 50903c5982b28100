"""MAVLink 2 links over TCP and UDP with a background reader thread.

A reader thread receives bytes and feeds them to a *stateful* pymavlink parser (a TCP
``recv`` may carry half a message or several), then puts every decoded message on a queue.
Sending is thread-safe (one lock around encoding and ``send``). Links never print; they log.

* :class:`TcpServerLink` - listen, accept one peer (the simulator side of PX4 SITL).
* :class:`TcpClientLink` - connect with retries (what PX4 does; used by the fake PX4 peer).
* :class:`UdpLink` - bind a local port, send to a remote address and, optionally, reply to
  whoever sent last (PX4's MAVLink instances and vinecli's vehicle endpoint).
"""

from __future__ import annotations

import contextlib
import logging
import queue
import socket
import threading
import time
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2

from vinecli.errors import AutopilotError, AutopilotTimeout, VinecliError

log = logging.getLogger(__name__)

MAV = mavlink2
Message = mavlink2.MAVLink_message


def is_loopback(host: str) -> bool:
    """True when ``host`` resolves to a loopback IP (127.0.0.0/8, ::1); a name like
    ``127.0.0.1.example.org`` is resolved, not prefix-matched. False if it does not resolve."""
    import ipaddress

    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        pass
    try:
        infos = socket.getaddrinfo(host, None)
    except (OSError, UnicodeError):
        return False
    return bool(infos) and all(ipaddress.ip_address(i[4][0]).is_loopback for i in infos)


class Link:
    """Common part: a parser, a queue of received messages, thread-safe send."""

    def __init__(self, src_system: int = 1, src_component: int = 1, name: str = "link") -> None:
        self.name = name
        self._tx = mavlink2.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
        self._tx.robust_parsing = True
        self._rx = mavlink2.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
        self._rx.robust_parsing = True
        self.inbox: queue.Queue[Message] = queue.Queue()
        self._tx_lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.closed_by_peer = threading.Event()
        #: called in the reader thread with every decoded message before it is queued (state tracking
        #: that must not wait for a consumer thread to be scheduled)
        self.on_message: Any = None
        self.rx_count = 0
        self.tx_count = 0
        #: bytes received, and those that made up the messages decoded: the difference is garbage, or a frame the
        #: parser still waits to complete (which garbage claiming a long frame makes it wait for in vain)
        self.rx_bytes = 0
        self.decoded_bytes = 0

    @property
    def mav(self) -> mavlink2.MAVLink:
        """The encoder (``link.mav.heartbeat_encode(...)`` builds a message to :meth:`send`)."""
        return self._tx

    # ---------------------------------------------------------------- receiving
    def _feed(self, data: bytes, parser: mavlink2.MAVLink | None = None) -> None:
        """Parse ``data`` with ``parser`` (default: the link's own) and deliver every valid message."""
        self.rx_bytes += len(data)
        msgs = (parser or self._rx).parse_buffer(data)
        if msgs:
            good = [m for m in msgs if m.get_type() != "BAD_DATA"]
            # a frame of an unknown id cannot be checked (its CRC seed is unknown): garbage that claims a frame
            # comes out as one, so it counts as undecoded
            self.decoded_bytes += sum(len(m.get_msgbuf()) for m in good if not m.get_type().startswith("UNKNOWN"))
            self._deliver(good)

    def _deliver(self, msgs: list[Message]) -> None:
        """Count, hand to ``on_message`` (in the reader thread) and queue decoded messages."""
        for m in msgs:
            self.rx_count += 1
            if self.on_message is not None:
                try:
                    self.on_message(m)
                except Exception:  # noqa: BLE001 - a handler bug must not kill the reader thread
                    log.exception("%s: message handler failed on %s", self.name, m.get_type())
            self.inbox.put(m)

    @property
    def undecoded_bytes(self) -> int:
        """Bytes received that are not (yet) part of a decoded message."""
        return self.rx_bytes - self.decoded_bytes

    def _start_reader(self) -> None:
        self._thread = threading.Thread(target=self._reader, name=f"mavlink-{self.name}", daemon=True)
        self._thread.start()

    def _reader(self) -> None:  # pragma: no cover - overridden
        raise AutopilotError("reader not implemented")

    def _read_stream(self, sock: socket.socket, parser: mavlink2.MAVLink | None = None, *,
                     mark_closed: bool = True) -> None:
        """Reader loop of a connected TCP socket: feed bytes (to ``parser``, default the link's) until stop,
        EOF or error, then set ``closed_by_peer`` if ``mark_closed``."""
        while not self._stop.is_set():
            try:
                data = sock.recv(65536)
            except TimeoutError:
                continue
            except OSError:
                break
            if not data:
                break
            self._feed(data, parser)
        if mark_closed:
            self.closed_by_peer.set()

    def recv(self, timeout: float | None = None) -> Message | None:
        """Next received message, or None after ``timeout`` seconds."""
        try:
            return self.inbox.get(timeout=timeout)
        except queue.Empty:
            return None

    def recv_match(self, types: set[str] | str, timeout: float, cond: Any = None) -> Message | None:
        """First message of one of ``types`` (and ``cond(msg)`` true) within ``timeout`` s; others are dropped."""
        if isinstance(types, str):
            types = {types}
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            m = self.recv(left)
            if m is not None and m.get_type() in types and (cond is None or cond(m)):
                return m

    def drain(self) -> list[Message]:
        """All messages received so far (non-blocking)."""
        out = []
        while True:
            try:
                out.append(self.inbox.get_nowait())
            except queue.Empty:
                return out

    # ---------------------------------------------------------------- sending
    def send(self, msg: Message) -> None:
        """Encode (MAVLink 2) and send one message."""
        with self._tx_lock:
            buf = msg.pack(self._tx)
            self._tx.seq = (self._tx.seq + 1) % 256
            self._send_bytes(buf)
            self.tx_count += 1

    def send_raw(self, msgid: int, crc_extra: int, payload: bytes) -> None:
        """Send a MAVLink 2 message this pymavlink dialect lacks (e.g. PROTOCOL_VERSION 300)."""
        from pymavlink.generator.mavcrc import x25crc

        while len(payload) > 1 and payload[-1] == 0:  # MAVLink 2 payload truncation
            payload = payload[:-1]
        with self._tx_lock:
            hdr = bytes([0xFD, len(payload), 0, 0, self._tx.seq, self._tx.srcSystem, self._tx.srcComponent,
                         msgid & 0xFF, (msgid >> 8) & 0xFF, (msgid >> 16) & 0xFF])
            crc = x25crc(hdr[1:] + payload)
            crc.accumulate(bytes([crc_extra]))
            self._tx.seq = (self._tx.seq + 1) % 256
            self._send_bytes(hdr + payload + bytes([crc.crc & 0xFF, crc.crc >> 8]))
            self.tx_count += 1

    def _send_bytes(self, buf: bytes) -> None:  # pragma: no cover - overridden
        raise AutopilotError("send not implemented")

    def close(self) -> None:
        """Stop the reader and close sockets. Idempotent."""
        self._stop.set()
        self._close_sockets()
        t = self._thread
        if t is not None and t is not threading.current_thread():
            t.join(timeout=1.0)

    def _close_sockets(self) -> None:  # pragma: no cover - overridden
        """Close the subclass's sockets (the base class has none)."""


def listening_tcp_socket(bind: tuple[str, int], backlog: int, error: type[VinecliError], *, hint: str = "") -> socket.socket:
    """A TCP socket listening on ``bind`` (SO_REUSEADDR: the last run's connections in TIME_WAIT do not block
    it); ``error`` (one line naming the address, then ``hint``) if the bind fails."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind(bind)
    except OSError as exc:
        sock.close()
        raise error(f"cannot listen on TCP {bind[0]}:{bind[1]}: {exc.strerror or exc}{hint}") from None
    sock.listen(backlog)
    return sock


class TcpServerLink(Link):
    """Listen on ``host:port`` and accept exactly one peer (Gazebo-classic / jMAVSim role)."""

    def __init__(self, host: str, port: int, *, src_system: int = 1, src_component: int = 200) -> None:
        super().__init__(src_system, src_component, name=f"tcp-server-{port}")
        self.host, self.port = host, port
        self._srv = listening_tcp_socket((host, port), 1, AutopilotError, hint=" (another simulator running?)")
        self.port = self._srv.getsockname()[1]
        self._conn: socket.socket | None = None
        self.peer: tuple[str, int] | None = None

    def accept(self, timeout: float, hint: str = "") -> None:
        """Wait up to ``timeout`` s for the peer; AutopilotTimeout naming host:port (and ``hint``) otherwise."""
        self._srv.settimeout(timeout)
        try:
            conn, addr = self._srv.accept()
        except TimeoutError:
            raise AutopilotTimeout(
                f"PX4 did not connect to TCP {self.host}:{self.port} within {timeout:g} s" + (f"; start it with: {hint}" if hint else "")
            ) from None
        except OSError as exc:
            raise AutopilotError(f"TCP {self.host}:{self.port}: accept failed: {exc}") from None
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        conn.settimeout(0.2)
        self._conn, self.peer = conn, (addr[0], addr[1])
        log.info("PX4 connected from %s:%d on TCP %d", addr[0], addr[1], self.port)
        self._start_reader()

    def _reader(self) -> None:
        assert self._conn is not None
        self._read_stream(self._conn)

    def _send_bytes(self, buf: bytes) -> None:
        if self._conn is None:
            raise AutopilotError(f"TCP {self.host}:{self.port}: no peer connected")
        try:
            self._conn.sendall(buf)
        except OSError as exc:
            self.closed_by_peer.set()
            raise AutopilotError(f"TCP {self.host}:{self.port}: connection to PX4 lost ({exc.strerror or exc})") from None

    def _close_sockets(self) -> None:
        if self._conn is not None:
            with contextlib.suppress(OSError):
                self._conn.shutdown(socket.SHUT_RDWR)  # wakes the reader now, not at its next 0.2 s timeout
        for s in (self._conn, self._srv):
            if s is not None:
                with contextlib.suppress(OSError):
                    s.close()


class TcpClientLink(Link):
    """Connect to ``host:port``, retrying until ``timeout`` (PX4's simulator_mavlink role)."""

    def __init__(self, host: str, port: int, *, src_system: int = 1, src_component: int = 1) -> None:
        super().__init__(src_system, src_component, name=f"tcp-client-{port}")
        self.host, self.port = host, port
        self._sock: socket.socket | None = None

    def connect(self, timeout: float, retry_s: float = 0.02, stop: threading.Event | None = None) -> bool:
        """Retry ``connect()`` until accepted (True) or ``timeout``/``stop`` (False)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not (stop is not None and stop.is_set()):
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            try:
                s.connect((self.host, self.port))
            except OSError:
                s.close()
                time.sleep(retry_s)
                continue
            s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            s.settimeout(0.2)
            self._sock = s
            self._start_reader()
            return True
        return False

    def _reader(self) -> None:
        assert self._sock is not None
        self._read_stream(self._sock)

    def _send_bytes(self, buf: bytes) -> None:
        if self._sock is None:
            raise AutopilotError(f"TCP {self.host}:{self.port}: not connected")
        self._sock.sendall(buf)

    def _close_sockets(self) -> None:
        if self._sock is not None:
            with contextlib.suppress(OSError):
                self._sock.shutdown(socket.SHUT_RDWR)
            self._sock.close()


def bound_udp_socket(bind: tuple[str, int], error: type[VinecliError], *, reuse_addr: bool = False) -> socket.socket:
    """A UDP socket bound to ``bind`` with a 0.2 s receive timeout (the reader threads poll their stop flag);
    ``error`` (one line naming the address) if the bind fails."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    if reuse_addr:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind(bind)
    except OSError as exc:
        sock.close()
        raise error(f"cannot bind UDP {bind[0]}:{bind[1]}: {exc.strerror or exc}") from None
    sock.settimeout(0.2)
    return sock


class UdpLink(Link):
    """A UDP MAVLink endpoint bound to ``bind`` that sends to ``remote``.

    With ``reply_to_sender`` the remote becomes the address of the last datagram received
    (PX4's MAVLink instances and QGC-style endpoints behave this way).
    """

    def __init__(
        self,
        bind: tuple[str, int],
        remote: tuple[str, int] | None = None,
        *,
        reply_to_sender: bool = True,
        src_system: int = 1,
        src_component: int = 1,
        on_message: Any = None,
    ) -> None:
        super().__init__(src_system, src_component, name=f"udp-{bind[1]}")
        self.on_message = on_message
        self._sock = bound_udp_socket(bind, AutopilotError, reuse_addr=True)
        self.local = self._sock.getsockname()
        self.remote = remote
        self.reply_to_sender = reply_to_sender
        self.last_sender: tuple[str, int] | None = None
        self._start_reader()

    def _reader(self) -> None:
        while not self._stop.is_set():
            try:
                data, addr = self._sock.recvfrom(65536)
            except TimeoutError:
                continue
            except OSError:
                break
            if self._stop.is_set():  # closing (the wake-up datagram of close())
                break
            self.last_sender = (addr[0], addr[1])
            if self.reply_to_sender:
                self.remote = self.last_sender
            self._feed(data)

    def _send_bytes(self, buf: bytes) -> None:
        if self.remote is None:
            return  # nobody to talk to yet (udpin without a peer)
        try:
            self._sock.sendto(buf, self.remote)
        except OSError as exc:  # e.g. ECONNREFUSED from a previous ICMP: UDP is best effort
            log.debug("UDP send to %s failed: %s", self.remote, exc)

    def _close_sockets(self) -> None:
        with contextlib.suppress(OSError):  # an empty datagram wakes the reader now, not at its next 0.2 s timeout
            self._sock.sendto(b"", self._sock.getsockname())
        self._sock.close()


def parse_endpoint(url: str) -> tuple[str, str, int]:
    """'udp:HOST:PORT' / 'udpin:...' / 'udpout:...' / 'tcp:...' -> (scheme, host, port); InputError if malformed."""
    from vinecli.errors import InputError

    parts = url.replace("://", ":").split(":")
    if len(parts) != 3 or parts[0] not in ("udp", "udpin", "udpout", "tcp", "tcpin"):
        raise InputError(f"bad MAVLink endpoint {url!r}: expected udp:HOST:PORT (e.g. udp:127.0.0.1:14540)")
    try:
        port = int(parts[2])
    except ValueError:
        raise InputError(f"bad MAVLink endpoint {url!r}: port {parts[2]!r} is not a number") from None
    if not 0 < port < 65536:
        raise InputError(f"bad MAVLink endpoint {url!r}: port out of range")
    return parts[0], parts[1], port
