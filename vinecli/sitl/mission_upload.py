"""Mission upload to a firmware (MAVLink mission protocol), stepped in simulated time: no waiting.

MISSION_COUNT -> the firmware asks for each item (MISSION_REQUEST_INT, or the legacy MISSION_REQUEST)
-> MISSION_ITEM_INT -> MISSION_ACK. :class:`MissionUpload` is fed every message (:meth:`on_message`)
and the simulated time (:meth:`tick`); it sends MISSION_COUNT again after ``resend_us`` without a
request, and fails after ``timeout_us`` of simulated time. Used for mission items (type 0) and fence
items (type 1) by every firmware bridge.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

from vinecli.errors import AutopilotError, AutopilotTimeout

MISSION_RESULTS = {0: "ACCEPTED", 1: "ERROR", 2: "UNSUPPORTED_FRAME", 3: "UNSUPPORTED", 4: "NO_SPACE", 5: "INVALID",
                   6: "INVALID_PARAM1", 7: "INVALID_PARAM2", 8: "INVALID_PARAM3", 9: "INVALID_PARAM4", 10: "INVALID_PARAM5_X", 11: "INVALID_PARAM6_Y", 12: "INVALID_PARAM7",
                   13: "INVALID_SEQUENCE", 14: "DENIED", 15: "OPERATION_CANCELLED"}
TYPE_NAMES = {0: "mission", 1: "geofence", 2: "rally points"}


class Sender(Protocol):
    mav: Any

    def send(self, msg: Any) -> None: ...


class Item(Protocol):
    def encode(self, mav: object, seq: int, target_system: int, target_component: int, current: int = 0) -> object: ...


class MissionUpload:
    """One upload of ``items`` as ``mission_type`` to ``target_system`` (``done`` once acknowledged)."""

    def __init__(self, items: Sequence[Item], mission_type: int, target_system: int, *, target_component: int = 1,
                 firmware: str = "the firmware", resend_us: int = 1_000_000, timeout_us: int = 20_000_000) -> None:
        self.items = list(items)
        self.mission_type = mission_type
        self.target, self.component = target_system, target_component
        self.firmware = firmware
        self.resend_us, self.timeout_us = resend_us, timeout_us
        self.what = TYPE_NAMES.get(mission_type, f"mission type {mission_type}")
        self.done = False
        self._t0: int | None = None
        self._t_last = 0
        self.requested: set[int] = set()

    def start(self, link: Sender, t_us: int) -> None:
        """Send MISSION_COUNT at simulated time ``t_us``."""
        self._t0 = self._t_last = t_us
        link.send(link.mav.mission_count_encode(self.target, self.component, len(self.items), self.mission_type))

    def on_message(self, m: Any, link: Sender, t_us: int) -> None:
        """Answer an item request or take the final MISSION_ACK (AutopilotError if the upload was refused)."""
        if self.done or self._t0 is None or getattr(m, "mission_type", 0) != self.mission_type:
            return
        typ = m.get_type()
        if typ == "MISSION_ACK":
            if m.type != 0:
                raise AutopilotError(f"{self.firmware} rejected the {self.what} upload: MISSION_ACK "
                                     f"{MISSION_RESULTS.get(m.type, m.type)}")
            if len(self.requested) == len(self.items):
                self.done = True
            return
        if typ not in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            return
        if not 0 <= m.seq < len(self.items):
            raise AutopilotError(f"{self.firmware} requested {self.what} item {m.seq} of {len(self.items)}")
        self._t_last = t_us
        self.requested.add(m.seq)
        link.send(self.items[m.seq].encode(link.mav, m.seq, self.target, self.component,
                                           current=1 if m.seq == 0 else 0))

    def tick(self, link: Sender, t_us: int) -> None:
        """Send MISSION_COUNT again after a silence; AutopilotTimeout after ``timeout_us`` in all."""
        if self.done or self._t0 is None:
            return
        if t_us - self._t0 > self.timeout_us:
            raise AutopilotTimeout(f"{self.firmware}: the {self.what} upload did not complete within "
                                   f"{self.timeout_us / 1e6:g} s of simulated time "
                                   f"({len(self.requested)} of {len(self.items)} items requested)")
        if t_us - self._t_last >= self.resend_us:
            self._t_last = t_us
            link.send(link.mav.mission_count_encode(self.target, self.component, len(self.items), self.mission_type))


__all__ = ["MISSION_RESULTS", "MissionUpload"]
