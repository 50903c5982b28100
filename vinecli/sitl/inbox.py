"""A firmware's MAVLink output handed to the ground station at frames fixed by the firmware's own output order.

In lockstep the firmware's *input* is consumed deterministically: what vinecli sends before answering a
servo frame is in the firmware's socket before its clock moves, and ArduPilot reads its serial ports at
fixed points of its simulated clock (``Scheduler::stop_clock`` runs the UART I/O every 10 ms of it). Its
*output* is not: when the bytes it wrote to its TCP port reach vinecli's socket, relative to the servo
frames it sends over UDP, is up to the kernel's scheduling (on a loaded machine, frames later; the
loopback test of this module sees it too). A ground station acting on what it polled at each frame
therefore acts at frames that depend on the load: the same seed flown twice beside a CPU hog armed 4 ms
apart and diverged.

:class:`OrderedInbox` puts sequence points into the firmware's output stream and releases messages only at
them. Every ``period`` frames it sends a MAVLink TIMESYNC request (``tc1 = 0``, ``ts1`` = the frame index);
the firmware answers it (``tc1`` = its time, ``ts1`` echoed) when its main loop handles it (ArduPilot:
``GCS_MAVLINK::handle_timesync``), in order with everything else it writes on that port. The messages that
arrived before the answer to the marker of frame ``f`` and after the previous answer form one batch,
released to the ground station at frame ``f + lag``: what the firmware wrote before handling a request it
read at a given simulated time, i.e. a function of the firmware's own execution, not of the arrival time.
If that answer has not arrived when its batch is due, the inbox waits for it on the socket, up to
``flush_wait_s`` of wall time: the firmware is blocked until the physics answers, so either it wrote the
answer already and the kernel delivers it within milliseconds, or it has not handled the request yet (while
it boots, before its MAVLink is up, it answers up to 19 frames late), and then no waiting brings it: the batch
is postponed to the next frame, the same on every run (``postponed``). The wait ends at once when the link
closes or the firmware dies (``alive``). A firmware that skipped a request (ArduPilot drops one when its
send buffer is full; it never answers the first marker of its boot) shows it by answering a later
marker first: the skipped marker's batch is empty and its messages go with the next one, on every run.
A marker postponed ``max_postpone`` times is given up (``late``: what arrived is released; that run may
not repeat to the bit).
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable
from typing import Any, Protocol

log = logging.getLogger(__name__)

#: frames between two markers (20 ms at 250 Hz)
MARKER_PERIOD = 5
#: frames from a marker to the release of the messages before its answer (80 ms at 250 Hz): ArduPilot's answers
#: arrive 2-9 frames after the marker, and 14-19 for those it read while booting (then it would have to wait)
MARKER_LAG = 20
#: wall seconds an answer the firmware wrote may take to arrive (the kernel's delay, milliseconds under load)
FLUSH_WAIT_S = 0.5
#: frames a due marker may be postponed (its answer not written yet) before it is given up
MAX_POSTPONE = 25


class Link(Protocol):
    mav: Any
    closed_by_peer: bool

    def poll(self) -> list[Any]: ...

    def send(self, msg: Any) -> None: ...

    def wait_readable(self, timeout_s: float) -> bool: ...


class OrderedInbox:
    """The messages of ``link`` released in batches cut by TIMESYNC markers (module docstring).

    Call :meth:`frame` once per lockstep frame once the link is up, while the firmware waits for the
    physics' answer. Counters: ``markers`` sent, ``dropped`` (the firmware answered a later marker first),
    ``postponed`` (frames at which a due answer was not written yet), ``late`` (markers given up after
    ``max_postpone`` such frames), ``waits`` and ``waited_s`` (frames that waited for an answer on the socket,
    and the wall time spent), ``max_latency`` (most frames from a marker to its answer as they arrived: a
    diagnostic of the margin, not deterministic)."""

    def __init__(self, link: Link, *, period: int = MARKER_PERIOD, lag: int = MARKER_LAG,
                 flush_wait_s: float = FLUSH_WAIT_S, max_postpone: int = MAX_POSTPONE,
                 alive: Callable[[], bool] | None = None) -> None:
        if not 0 < period <= lag:
            raise ValueError(f"OrderedInbox: need 0 < period ({period}) <= lag ({lag})")
        self.link, self.period, self.lag = link, period, lag
        self.flush_wait_s, self.max_postpone, self.alive = flush_wait_s, max_postpone, alive
        self.frames = 0
        self._loose: list[Any] = []  # arrived after the last answer
        self._outstanding: deque[int] = deque()  # markers sent and not answered, oldest first
        self._batches: dict[int, list[Any]] = {}  # marker -> the messages written before its answer
        self._due: deque[int] = deque()  # markers whose batch is not released yet, oldest first
        self._postponed_at: dict[int, int] = {}  # marker -> frames it was postponed
        self.markers = self.dropped = self.postponed = self.late = self.waits = self.max_latency = 0
        self.waited_s = 0.0

    def frame(self) -> list[Any]:
        """The messages released at this frame, in the firmware's order; then this frame's marker."""
        f = self.frames
        self.frames += 1
        self._receive(f)
        out: list[Any] = []
        while self._due and self._due[0] + self.lag <= f:
            marker = self._due[0]
            if marker in self._outstanding and not self._wait_for(marker, f):
                break  # the firmware has not written that answer yet: due again at the next frame
            self._due.popleft()
            out += self._batches.pop(marker, [])
        if f % self.period == 0:
            self.link.send(self.link.mav.timesync_encode(0, f))
            self._outstanding.append(f)
            self._due.append(f)
            self.markers += 1
        return out

    def _receive(self, f: int) -> None:
        for m in self.link.poll():
            if m.get_type() == "TIMESYNC" and m.tc1 != 0:  # an answer (the firmware's own requests have tc1 0)
                self._cut(int(m.ts1), f)
            else:
                self._loose.append(m)

    def _cut(self, marker: int, f: int) -> None:
        """The answer to ``marker``: what arrived before it is that marker's batch."""
        if marker not in self._outstanding:
            return  # given up on (late): what came before it was released already
        while self._outstanding[0] != marker:  # answers come in order: the firmware skipped the older ones
            self._batches[self._outstanding.popleft()] = []
            self.dropped += 1
        self._outstanding.popleft()
        self._batches[marker] = self._loose
        self._loose = []
        self.max_latency = max(self.max_latency, f - marker)

    def _wait_for(self, marker: int, f: int) -> bool:
        """Wait up to ``flush_wait_s`` (wall) for the answer to ``marker``; False if it did not come (the
        firmware has not written it: postponed), True once it came or the marker is given up (``late``)."""
        t0 = time.monotonic()
        self.waits += 1
        while marker in self._outstanding:
            left = self.flush_wait_s - (time.monotonic() - t0)
            if left <= 0 or self.link.closed_by_peer or (self.alive is not None and not self.alive()):
                break
            if self.link.wait_readable(min(left, 0.1)):
                self._receive(f)
        self.waited_s += time.monotonic() - t0
        if marker in self._outstanding:
            self._receive(f)  # what came while this process was not running
        if marker not in self._outstanding:
            return True
        if self.link.closed_by_peer:
            return False
        n = self._postponed_at[marker] = self._postponed_at.get(marker, 0) + 1
        self.postponed += 1
        if n < self.max_postpone:
            return False
        self.late += 1
        log.warning("no answer to the MAVLink marker of frame %d at %d frames past its lag: releasing what arrived",
                    marker, n)
        self._outstanding.remove(marker)
        self._batches[marker] = self._loose
        self._loose = []
        return True


__all__ = ["FLUSH_WAIT_S", "MARKER_LAG", "MARKER_PERIOD", "MAX_POSTPONE", "OrderedInbox"]
