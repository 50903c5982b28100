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
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from vinecli.errors import AutopilotError


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
        """Every complete message received since the last poll (none before connecting)."""
        s = self.sock
        if s is None:
            return []
        out: list[Any] = []
        while True:
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
        except OSError as exc:
            self.closed_by_peer = True
            raise AutopilotError(f"{self.name}: MAVLink link on TCP {self.host}:{self.port} lost "
                                 f"({exc.strerror or exc})") from None
        finally:
            if self.sock is not None:
                s.setblocking(False)

    def close(self) -> None:
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
