"""A MAVLink link to a firmware that is read only when polled: no reader thread.

What the firmware sent is handled in the caller's thread at a point the caller chooses: in lockstep, while
the firmware is blocked waiting for the physics' answer. What vinecli sends before that answer is in the
firmware's socket before its clock moves again, so the firmware consumes it at a fixed simulated time. The
other direction is not ordered with the lockstep: when the firmware's bytes reach this socket, relative to
its servo frames, depends on the kernel and the machine's load. A ground station that must act at the same
frame on every run reads through :class:`vinecli.sitl.inbox.OrderedInbox`, not :meth:`PolledTcpLink.poll`.
"""

from __future__ import annotations

import select
import socket
import time
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from vinecli.errors import AutopilotError
from vinecli.sitl.delivery import PeerReceipt

#: most socket reads (of up to 64 kB) one :meth:`PolledTcpLink.poll` makes
POLL_READS = 64


class PolledTcpLink:
    """MAVLink 2 over TCP to ``host:port`` (the firmware listens), ArduPilot dialect (a superset of common)."""

    def __init__(self, host: str, port: int, *, src_system: int = 255, src_component: int = 190,
                 name: str = "firmware") -> None:
        self.host, self.port, self.name = host, port, name
        self.mav = mavlink2.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
        self._rx = mavlink2.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
        self._rx.robust_parsing = True
        self.sock: socket.socket | None = None
        self.closed_by_peer = False
        self.rx_count = 0
        self.tx_bytes = 0  # bytes handed to the kernel since connecting
        self._confirmed = 0  # of which the firmware's socket is known to hold
        self.receipt = PeerReceipt()

    @property
    def connected(self) -> bool:
        return self.sock is not None

    def try_connect(self) -> bool:
        """One connection attempt (loopback: at once or refused); True once connected."""
        if self.sock is not None:
            return True
        try:
            s = socket.create_connection((self.host, self.port), timeout=1.0)
        except OSError:
            return False
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        s.setblocking(False)
        self.sock = s
        return True

    def poll(self) -> list[Any]:
        """Every complete message received since the last poll (none before connecting); at most
        :data:`POLL_READS` reads, so a firmware that floods its port returns control to the caller's checks."""
        s = self.sock
        if s is None:
            return []
        out: list[Any] = []
        for _ in range(POLL_READS):
            try:
                data = s.recv(1 << 16)
            except BlockingIOError:
                break
            except OSError:
                self.closed_by_peer = True
                break
            if not data:
                self.closed_by_peer = True
                break
            out += [m for m in (self._rx.parse_buffer(data) or []) if m.get_type() != "BAD_DATA"]
        self.rx_count += len(out)
        return out

    def wait_readable(self, timeout_s: float) -> bool:
        """Block up to ``timeout_s`` of wall time until the firmware's bytes (or its close) can be read."""
        s = self.sock
        if s is None:
            return False
        return bool(select.select([s], [], [], max(0.0, timeout_s))[0])

    def send(self, msg: Any) -> None:
        """Encode and send one message (AutopilotError when the firmware closed the link)."""
        s = self.sock
        if s is None:
            raise AutopilotError(f"{self.name}: MAVLink sent before connecting to TCP {self.host}:{self.port}")
        buf = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        try:
            s.setblocking(True)
            s.sendall(buf)
            self.tx_bytes += len(buf)
        except OSError as exc:
            self.closed_by_peer = True
            raise AutopilotError(f"{self.name}: MAVLink link on TCP {self.host}:{self.port} lost "
                                 f"({exc.strerror or exc})") from None
        finally:
            if self.sock is not None:
                s.setblocking(False)

    def wait_received(self, timeout_s: float) -> bool | None:
        """Wait (up to ``timeout_s`` of wall time) until the firmware's socket holds every byte sent
        (:mod:`vinecli.sitl.delivery`). True at once if it does, False if it had to wait, None if the kernel
        cannot say or the bytes did not arrive in time (the caller counts that: no guarantee for the frame)."""
        s = self.sock
        if s is None or self.closed_by_peer or self._confirmed >= self.tx_bytes:
            return True
        deadline = time.monotonic() + timeout_s
        waited = False
        while True:
            got = self.receipt.received(s)
            if got is None:
                return None
            if got >= self.tx_bytes:
                self._confirmed = got
                return not waited
            if time.monotonic() >= deadline:
                return None
            waited = True
            time.sleep(0.0002)  # the kernel's softirq thread needs the CPU this process would spin on

    def close(self) -> None:
        self.receipt.close()
        if self.sock is not None:
            self.sock.close()
            self.sock = None


def param_name(m: Any) -> str:
    """The parameter name of a PARAM_VALUE (bytes or str, NUL padded)."""
    pid = m.param_id
    if isinstance(pid, bytes):
        pid = pid.decode(errors="replace")
    return str(pid).rstrip("\x00")


def statustext(m: Any) -> str:
    """The text of a STATUSTEXT (bytes or str, NUL padded)."""
    raw = m.text if isinstance(m.text, str) else m.text.decode(errors="replace")
    return raw.split("\x00", 1)[0].strip()


__all__ = ["PolledTcpLink", "param_name", "statustext"]
