"""The ordered inbox (vinecli/sitl/inbox.py) against a scripted firmware over a real TCP socket: what the
ground station is handed at each frame depends on the firmware's output order only, not on when its bytes
arrive (immediately, or held back and trickled in from another thread as a loaded kernel does)."""

from __future__ import annotations

import queue
import random
import socket
import threading
import time
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from vinecli.sitl.inbox import OrderedInbox
from vinecli.sitl.polled_link import PolledTcpLink, statustext


class ScriptedFirmware:
    """Lockstep firmware: loop ``k`` reads what the ground station sent, writes ``STATUSTEXT "loop k"`` and
    answers the TIMESYNC requests it read ``handle_after`` loops earlier (except those in ``skip``).
    ``trickle``: its bytes reach the socket from a thread, in random pieces after random wall delays."""

    def __init__(self, *, trickle: bool, seed: int = 0, handle_after: int = 2, skip: frozenset[int] = frozenset(),
                 stop_answering_at: int | None = None) -> None:
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
        self.rx = mavlink2.MAVLink(None)
        self.trickle, self.rng = trickle, random.Random(seed)
        self.handle_after, self.skip, self.stop_at = handle_after, skip, stop_answering_at
        self.requests: list[tuple[int, int]] = []  # (loop that read it, ts1)
        self.conn: socket.socket | None = None
        self.out: queue.Queue[bytes | None] = queue.Queue()
        self.writer = threading.Thread(target=self._deliver, daemon=True)

    def accept(self) -> None:
        self.conn, _ = self.server.accept()
        self.writer.start()

    def _deliver(self) -> None:
        assert self.conn is not None
        while (data := self.out.get()) is not None:
            while data:
                time.sleep(self.rng.uniform(0.0, 0.002))
                n = self.rng.randint(1, len(data))
                self.conn.sendall(data[:n])
                data = data[n:]

    def _write(self, msg: Any) -> None:
        buf = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        if self.trickle:
            self.out.put(buf)
        else:
            assert self.conn is not None
            self.conn.sendall(buf)

    def loop(self, k: int, expected_requests: int) -> None:
        assert self.conn is not None
        while len(self.requests) < expected_requests:  # what was sent before this loop (lockstep input)
            for m in self.rx.parse_buffer(self.conn.recv(4096)) or []:
                if m.get_type() == "TIMESYNC":
                    self.requests.append((k, int(m.ts1)))
        self._write(self.mav.statustext_encode(6, f"loop {k}".encode()))
        for read_at, ts1 in self.requests:
            if read_at + self.handle_after == k and ts1 not in self.skip and (self.stop_at is None or k < self.stop_at):
                self._write(self.mav.timesync_encode(1000 + k, ts1))

    def close(self) -> None:
        self.out.put(None)
        self.writer.join(5)
        for s in (self.conn, self.server):
            if s is not None:
                s.close()


def _fly(fw: ScriptedFirmware, frames: int, **inbox_opts: Any) -> tuple[list[tuple[int, str]], OrderedInbox]:
    """The ground station's view: (frame, text) of every message the inbox released."""
    link = PolledTcpLink("127.0.0.1", fw.port)
    assert link.try_connect()
    fw.accept()
    inbox = OrderedInbox(link, **{"lag": 15, **inbox_opts})
    seen: list[tuple[int, str]] = []
    try:
        for k in range(frames):
            seen += [(k, statustext(m)) for m in inbox.frame()]
            fw.loop(k, inbox.markers)
    finally:
        fw.close()
        link.close()
    return seen, inbox


def test_what_is_released_at_each_frame_does_not_depend_on_when_the_bytes_arrive():
    ref, inbox = _fly(ScriptedFirmware(trickle=False), 200)
    assert inbox.markers == 40 and inbox.late == inbox.dropped == 0 and inbox.max_latency >= 3
    texts = [t for _, t in ref]
    assert texts == [f"loop {k}" for k in range(len(texts))] and len(texts) >= 180  # all, in order
    # the marker of frame f is answered in loop f + 2, after that loop's text: loops 0-2 go out at frame 0 + lag,
    # loops 3-7 at 5 + lag...
    at = {t: f for f, t in ref}
    assert (at["loop 0"], at["loop 2"], at["loop 3"], at["loop 7"], at["loop 8"]) == (15, 15, 20, 20, 25)
    for seed in range(3):
        got, late = _fly(ScriptedFirmware(trickle=True, seed=seed), 200)
        assert got == ref and late.late == 0 and late.waits > 0  # it waited for trickled answers


def test_a_marker_the_firmware_skipped_merges_its_batch_into_the_next_one_on_every_run():
    ref, inbox = _fly(ScriptedFirmware(trickle=False, skip=frozenset({50})), 120)
    assert inbox.dropped == 1 and inbox.late == 0
    assert not any(f == 65 for f, _ in ref) and [t for f, t in ref if f == 70] == [f"loop {k}" for k in range(48, 58)]
    got, _ = _fly(ScriptedFirmware(trickle=True, seed=7, skip=frozenset({50})), 120)
    assert got == ref


def test_an_answer_not_written_yet_postpones_its_batch_frame_by_frame():
    """A firmware that handles requests 16 frames after reading them (ArduPilot while it boots): each due batch
    waits for its answer a while, then goes out at the first frame after the answer, on every run."""
    seen, inbox = _fly(ScriptedFirmware(trickle=False, handle_after=16), 30, flush_wait_s=0.25)
    assert inbox.late == 0 and inbox.postponed == 3 * 2  # markers 0, 5, 10 were due 2 frames before their answers
    at = {t: f for f, t in seen}
    assert (at["loop 0"], at["loop 16"], at["loop 17"], at["loop 21"], at["loop 22"]) == (17, 17, 22, 22, 27)
    again, _ = _fly(ScriptedFirmware(trickle=True, handle_after=16), 30, flush_wait_s=0.25)
    assert again == seen


def test_an_unanswered_marker_is_given_up_after_a_bounded_wait():
    t0 = time.monotonic()
    seen, inbox = _fly(ScriptedFirmware(trickle=False, stop_answering_at=40), 80, flush_wait_s=0.02, max_postpone=3)
    assert inbox.late > 0 and inbox.waited_s < 2.0 and time.monotonic() - t0 < 10
    assert [t for _, t in seen] == [f"loop {k}" for k in range(len(seen))] and len(seen) > 60  # all, in order
    # a dead firmware ends each wait at once
    _, inbox = _fly(ScriptedFirmware(trickle=False, stop_answering_at=40), 80, flush_wait_s=30.0, alive=lambda: False)
    assert inbox.late > 0 and inbox.waited_s < 1.0


def test_parameters():
    with pytest.raises(ValueError, match="period"):
        OrderedInbox(PolledTcpLink("127.0.0.1", 1), period=20, lag=10)
