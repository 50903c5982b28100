"""Has the firmware's socket received every byte vinecli sent? (Linux ``sock_diag``, loopback TCP.)

In lockstep the firmware reads its MAVLink port at fixed points of its simulated clock (ArduPilot: every
10 ms of it, right after the physics answer lets the clock move). What vinecli sends before answering is
meant to be read at the first of those points. On loopback that holds only if the kernel has put the bytes
in the firmware's receive queue by the time the firmware wakes up on the answer, and nothing guarantees it:
the TCP segment and the answer's UDP datagram are separate packets, each processed in a softirq of the CPU
that sent it; on a loaded machine that processing is deferred to ``ksoftirqd`` (a thread that waits for a
CPU like any other), and when vinecli moved to the other CPU between the two sends the answer can overtake
the segment. The firmware then reads the message one read later: a parameter (the battery) or a command
takes effect a few milliseconds later and the flight is no longer the same to the bit.

:class:`PeerReceipt` asks the kernel (``NETLINK_SOCK_DIAG``, ``INET_DIAG_INFO``) for ``tcp_info.bytes_received``
of the *firmware's* end of the connection: once it equals what vinecli has sent, every byte is in the
firmware's receive queue. A TCP acknowledgement would say the same but comes late (the firmware's kernel
delays it until the firmware writes, and the firmware is blocked until the answer). No such interface
(another OS, a kernel without ``inet_diag``): :meth:`PeerReceipt.received` returns None and callers go on
without the check.
"""

from __future__ import annotations

import socket
import struct

_NETLINK_SOCK_DIAG = 4
_SOCK_DIAG_BY_FAMILY = 20
_NLM_F_REQUEST = 1
_NLMSG_ERROR = 2
_INET_DIAG_INFO = 2
_NLMSG_HDR = struct.Struct("=IHHII")
_INET_DIAG_MSG_LEN = 72
#: offset of ``tcpi_bytes_received`` (u64) in ``struct tcp_info`` (Linux >= 4.1)
_TCPI_BYTES_RECEIVED = 128
_ALL_STATES = 0xFFF
_NO_COOKIE = 0xFFFFFFFF


def _request(local: tuple[str, int], remote: tuple[str, int], seq: int) -> bytes:
    """An ``inet_diag_req_v2`` for the IPv4 TCP socket bound to ``local`` and connected to ``remote``."""
    sock_id = (struct.pack("!HH", local[1], remote[1]) + socket.inet_aton(local[0]) + bytes(12)
               + socket.inet_aton(remote[0]) + bytes(12) + struct.pack("=III", 0, _NO_COOKIE, _NO_COOKIE))
    req = struct.pack("=BBBBI", socket.AF_INET, socket.IPPROTO_TCP, 1 << (_INET_DIAG_INFO - 1), 0, _ALL_STATES)
    body = req + sock_id
    return _NLMSG_HDR.pack(_NLMSG_HDR.size + len(body), _SOCK_DIAG_BY_FAMILY, _NLM_F_REQUEST, seq, 0) + body


def _bytes_received(reply: bytes) -> int | None:
    """``tcpi_bytes_received`` from a sock_diag reply (None: an error reply or no INET_DIAG_INFO)."""
    if len(reply) < _NLMSG_HDR.size:
        return None
    length, kind = _NLMSG_HDR.unpack_from(reply)[:2]
    if kind != _SOCK_DIAG_BY_FAMILY:
        return None
    off = _NLMSG_HDR.size + _INET_DIAG_MSG_LEN
    end = min(length, len(reply))
    while off + 4 <= end:
        attr_len, attr_type = struct.unpack_from("=HH", reply, off)
        if attr_len < 4:
            return None
        if attr_type == _INET_DIAG_INFO and attr_len >= 4 + _TCPI_BYTES_RECEIVED + 8:
            return int(struct.unpack_from("=Q", reply, off + 4 + _TCPI_BYTES_RECEIVED)[0])
        off += (attr_len + 3) & ~3
    return None


class PeerReceipt:
    """Bytes received by the far end of a loopback TCP connection, as the kernel counts them."""

    def __init__(self) -> None:
        self._nl: socket.socket | None = None
        self._seq = 0
        self.available = hasattr(socket, "AF_NETLINK")

    def received(self, conn: socket.socket) -> int | None:
        """Bytes the peer of ``conn`` (an IPv4 TCP socket on this machine) has received from it; None if the
        kernel cannot say (then :attr:`available` turns False and later calls return None at once)."""
        if not self.available:
            return None
        try:
            mine, theirs = conn.getsockname(), conn.getpeername()
            if self._nl is None:
                self._nl = socket.socket(socket.AF_NETLINK, socket.SOCK_DGRAM, _NETLINK_SOCK_DIAG)
                self._nl.settimeout(1.0)
            self._seq += 1
            self._nl.send(_request(theirs, mine, self._seq))
            got = _bytes_received(self._nl.recv(65536))
        except OSError:
            got = None
        if got is None:
            self.available = False
            self.close()
        return got

    def close(self) -> None:
        if self._nl is not None:
            self._nl.close()
            self._nl = None


__all__ = ["PeerReceipt"]
