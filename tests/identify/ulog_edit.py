"""Edit a ULog's bytes the way damage does (attack tests): shift, restart or cut its clock partway through.

ULog (PX4's format): a 16-byte header, then messages ``uint16 size, uint8 type, body``; a data message ``D`` is
``uint16 msg_id`` followed by the topic's fields, the first of which is its ``uint64 timestamp`` (µs).
"""

from __future__ import annotations

import struct

HEADER = 16


def data_offsets(data: bytes) -> list[int]:
    """Byte offsets of the timestamps of every data message, in file order."""
    out, i = [], HEADER
    while i + 3 <= len(data):
        size, kind = struct.unpack_from("<HB", data, i)
        if kind == ord("D") and i + 3 + size <= len(data):
            out.append(i + 3 + 2)
        i += 3 + size
    return out


def retime(data: bytes, frac: float, fn) -> bytes:  # noqa: ANN001 - fn(timestamp_us) -> timestamp_us
    """``data`` with ``fn`` applied to the timestamp of every data message from ``frac`` of them on."""
    out = bytearray(data)
    offs = data_offsets(data)
    for off in offs[int(len(offs) * frac):]:
        (ts,) = struct.unpack_from("<Q", out, off)
        struct.pack_into("<Q", out, off, max(0, int(fn(ts))))
    return bytes(out)


def topic_ids(data: bytes, topic: str) -> set[int]:
    """The msg_ids a topic's data messages carry (its ``A`` subscriptions: ``uint8 multi_id, uint16 msg_id, name``)."""
    ids, i = set(), HEADER
    while i + 3 <= len(data):
        size, kind = struct.unpack_from("<HB", data, i)
        if kind == ord("A") and data[i + 6:i + 3 + size].decode(errors="replace") == topic:
            ids.add(struct.unpack_from("<H", data, i + 4)[0])
        i += 3 + size
    return ids


def shifted_topic(data: bytes, topic: str, frac: float, delta_us: int) -> bytes:
    """Only ``topic``'s clock jumps forward by ``delta_us`` from ``frac`` of its data messages on."""
    ids = topic_ids(data, topic)
    offs = [o for o in data_offsets(data) if struct.unpack_from("<H", data, o - 2)[0] in ids]
    out = bytearray(data)
    for off in offs[int(len(offs) * frac):]:
        (ts,) = struct.unpack_from("<Q", out, off)
        struct.pack_into("<Q", out, off, ts + delta_us)
    return bytes(out)


def shifted(data: bytes, frac: float, delta_us: int) -> bytes:
    """The clock jumps forward by ``delta_us`` at ``frac`` of the data messages."""
    return retime(data, frac, lambda ts: ts + delta_us)


def restarted(data: bytes, frac: float) -> bytes:
    """The clock restarts at 0 at ``frac`` of the data messages (a second boot spliced into the file)."""
    offs = data_offsets(data)
    (t_at,) = struct.unpack_from("<Q", data, offs[int(len(offs) * frac)])
    return retime(data, frac, lambda ts: ts - t_at)


def cut(data: bytes, frac: float) -> bytes:
    """The file cut at ``frac`` of its bytes (mid-message, as a full card or a pulled battery leaves it)."""
    return data[: int(len(data) * frac)]
