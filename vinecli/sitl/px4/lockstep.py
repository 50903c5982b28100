"""PX4's lockstep from the simulator's side: after HIL_SENSOR(t), wait for the HIL_ACTUATOR_CONTROLS answering it.

The wait, and what happens when PX4's answer does not come (docs/firmware-protocols.md §1):

* garbage on the link swallowed the answer (:meth:`Px4Lockstep._resync`, a stall);
* PX4 lost a wakeup (:meth:`Px4Lockstep._recover`): PX4 v1.15's sender thread waits in
  ``px4_lockstep_wait_for_components()`` for ekf2, the logger and the simulator module to report this step, and one
  report can be lost (likely in ``LockstepComponents::lockstep_progress``, which clears the progress bits after its
  check, not atomically with it), so PX4 waits for a clock that only the next HIL_SENSOR moves while vinecli waits for its
  answer. After :data:`RECOVER_S` of wall time the step flies with the last controls and the next HIL_SENSOR restarts
  PX4's clock (``px4_lockstep_recoveries``, an event);
* PX4 stopped: no answer for ``hang_timeout_s`` of wall time ends the run, naming the last exchange; with an explicit
  ``step_timeout_s`` each step waits that long instead and counts a stall.

A mixin of :class:`vinecli.sitl.px4.backend.Px4SitlAutopilot` (its link, process and counters).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from vinecli.errors import AutopilotError

if TYPE_CHECKING:
    from vinecli.mavlink.link import TcpServerLink

log = logging.getLogger(__name__)

RESYNC_S = 0.5  # wall s without PX4's answer, after garbage on the link, before the lockstep resynchronises
#: wall s without PX4's answer to one HIL_SENSOR before the lockstep sends the next one (PX4's lost wakeup, see _recover);
#: a PX4 step takes milliseconds, a SIGSTOP pause of 0.5 s stays a pause
RECOVER_S = 2.0


class Px4Lockstep:
    """The per-step wait for PX4's answer; the attributes are :class:`~vinecli.sitl.px4.backend.Px4SitlAutopilot`'s."""

    link: TcpServerLink | None
    process: Any
    host: str
    port: int
    dt_us: int
    step_timeout_s: float | None
    hang_timeout_s: float
    max_stalls: int
    stalls: int
    resyncs: int
    recoveries: int
    consecutive_stalls: int
    lockstep_steps: int
    #: PX4's last HIL_ACTUATOR_CONTROLS: its time_usec and the wall time (time.monotonic) it came
    _last_answer: tuple[int, float]
    _on_msg: Callable[[Any], None]  # the backend's message handler
    _emit: Callable[..., None]  # the backend's event list: (t_us, kind, message, data)
    _px4_log: Callable[[], str]  # the tail of PX4's log for an error message

    def _lockstep_wait(self, t: int) -> None:
        """PX4's HIL_ACTUATOR_CONTROLS for the HIL_SENSOR at ``t`` (see the module docstring)."""
        link = self.link
        assert link is not None
        bounded = self.step_timeout_s is not None
        limit = self.step_timeout_s if self.step_timeout_s is not None else min(RECOVER_S, self.hang_timeout_s)
        start = time.monotonic()
        junk0 = link.undecoded_bytes
        while True:
            left = start + limit - time.monotonic()
            m = link.recv(min(0.5, max(0.0, left))) if left > 0 else (link.recv(0.0) if not link.inbox.empty() else None)
            if m is not None:
                self._on_msg(m)
                if m.get_type() == "HIL_ACTUATOR_CONTROLS" and m.time_usec >= t:
                    self.consecutive_stalls = 0
                    self.lockstep_steps += 1
                    return
                continue
            if link.undecoded_bytes > junk0 and time.monotonic() - start >= RESYNC_S:
                self._resync(t, link.undecoded_bytes - junk0)
                return
            if link.closed_by_peer.is_set():
                raise AutopilotError(f"PX4 closed the simulator connection (TCP {self.host}:{self.port})" + self._px4_log())
            if self.process is not None and not self.process.alive():
                raise AutopilotError(f"PX4 exited (code {self.process.proc.returncode}) at {t / 1e6:.2f} s"
                                     + self._px4_log())
            if left <= 0:
                break
        if not bounded:
            if time.monotonic() - self._last_answer[1] < self.hang_timeout_s:
                self._recover(t)
                return
            raise AutopilotError(f"PX4 stopped answering on TCP {self.host}:{self.port}: no HIL_ACTUATOR_CONTROLS for "
                                 f"{self.hang_timeout_s:g} s of wall time (hung){self._hang_note(t)}" + self._px4_log())
        self.stalls += 1
        self.consecutive_stalls += 1
        if self.consecutive_stalls == 1 or self.stalls % 100 == 0:
            log.debug("lockstep stall at t=%d µs (%d total)", t, self.stalls)
        if self.consecutive_stalls >= self.max_stalls:
            raise AutopilotError(
                f"PX4 stopped answering on TCP {self.host}:{self.port}: no HIL_ACTUATOR_CONTROLS for "
                f"{self.consecutive_stalls} consecutive steps ({self.consecutive_stalls * limit:.1f} s)"
                + self._px4_log())

    def _recover(self, t: int) -> None:
        """No answer to HIL_SENSOR(``t``) for :data:`RECOVER_S`: PX4's lockstep lost a wakeup (docs/firmware-protocols.md
        §1, "PX4's lost wakeup"); the next step restarts its clock, this one flies with the last controls."""
        self.recoveries += 1
        self._emit(t - self.dt_us, "px4_lockstep_recovery",
                   f"PX4 did not answer HIL_SENSOR {t} µs within {RECOVER_S:g} s of wall time (a wakeup lost in PX4's "
                   f"lockstep, or PX4 paused): the step flew with the last controls and the next HIL_SENSOR went out to "
                   f"restart PX4's clock",
                   {"t_usec": t, "recovery": self.recoveries})

    def _hang_note(self, t: int) -> str:
        """The lockstep's last exchange, for the hang error (the last HIL_SENSOR sent, PX4's last answer)."""
        link, (ans_t, ans_wall) = self.link, self._last_answer
        assert link is not None
        return (f": HIL_SENSOR {t} µs sent, PX4's last answer {ans_t} µs {time.monotonic() - ans_wall:.1f} s ago, "
                f"{self.recoveries} recoveries; {link.rx_count} messages received, {link.undecoded_bytes} bytes undecoded")

    def _resync(self, t: int, bad: int) -> None:
        """Garbage swallowed PX4's one answer to HIL_SENSOR(``t``): go on with the last controls (a stall, as many raise)."""
        self.stalls, self.consecutive_stalls, self.resyncs = self.stalls + 1, self.consecutive_stalls + 1, self.resyncs + 1
        what = f"garbage on the simulator link (TCP {self.host}:{self.port}): {bad} bytes that decode to no message"
        self._emit(t - self.dt_us, "px4", f"{what}; PX4's answer was lost, resynchronised", {"undecoded_bytes": bad})
        if self.consecutive_stalls >= self.max_stalls:
            raise AutopilotError(f"{what}: {self.consecutive_stalls} steps in a row without PX4's answer" + self._px4_log())


__all__ = ["RECOVER_S", "RESYNC_S", "Px4Lockstep"]
