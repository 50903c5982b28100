"""A log's clock, as written: where it jumps or restarts, and the one continuous stretch a fit may use.

A flight log's time stamps come from one boot clock and only move forward, a few milliseconds at a time. A
log that says otherwise was damaged or spliced: the second half shifted by 10^12 µs (11 days: stepping over it
at 50 Hz would take 580 million steps), a clock that restarts at 0 halfway (two boots in one file), a logger
that stopped for minutes. :func:`continuous_stretch` cuts the reference stream (the IMU, logged fastest) where
its time, in file order, goes back by more than :data:`RESET_S` or forward by more than :data:`JUMP_S`, and
keeps the longest stretch; :meth:`Stretch.take` then picks each stream's samples of that stretch (same restart
count, same time span). When the IMU's clock is whole but another stream's alone jumps or restarts,
:meth:`Stretch.strays` finds that stream's samples that left it. The readers say so in a note. Sorting and de-duplicating small out-of-order steps is
:func:`vinecli.flightlog.arrays.sorted_stream`'s job, after this.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vinecli.errors import InputError
from vinecli.specs.limits import MAX_LOG_SPAN_S

__all__ = ["JUMP_S", "RESET_S", "Stretch", "continuous_stretch", "strays_note"]

#: a forward step of the clock longer than this is a jump, not a logging gap (gaps of seconds are gaps), s
JUMP_S = 60.0
#: a backward step longer than this is a restart of the clock (small ones are messages logged out of order), s
RESET_S = 1.0
#: samples of other streams this close to the stretch's ends belong to it (slower streams start later), s
EDGE_S = 2.0


@dataclass(frozen=True)
class Stretch:
    """One continuous stretch of a log's clock: the restart count ``epoch`` and the time span ``t0``..``t1`` (s,
    raw clock) it covers, ``note`` what was cut away ('' when nothing was)."""

    epoch: int
    t0: float
    t1: float
    note: str = ""

    def take(self, t: np.ndarray) -> np.ndarray:
        """Which samples of a stream (raw times ``t``, s, in file order) belong to the stretch."""
        t = np.asarray(t, dtype=float)
        return (epochs(t) == self.epoch) & (t >= self.t0 - EDGE_S) & (t <= self.t1 + EDGE_S)

    def take_state(self, t: np.ndarray) -> np.ndarray:
        """:meth:`take`, plus the stream's last sample before the stretch (a step function: the state it starts in)."""
        t = np.asarray(t, dtype=float)
        keep = self.take(t)
        before = np.flatnonzero((epochs(t) == self.epoch) & (t < self.t0 - EDGE_S))
        if before.size:
            keep[before[np.argmax(t[before])]] = True
        return keep


    def strays(self, t: np.ndarray) -> np.ndarray:
        """Which samples of another stream (raw times ``t``, s, in file order) left this stretch's clock: after a
        restart of their own, or later than :data:`JUMP_S` past its end (a stream whose clock alone jumped)."""
        t = np.asarray(t, dtype=float)
        return (epochs(t) != self.epoch) | (t > self.t1 + JUMP_S)


def strays_note(lost: dict[str, tuple[int, int]]) -> str:
    """The note for streams whose clock alone jumped: ``lost`` maps a stream's name to (samples dropped, of)."""
    which = ", ".join(f"{name} ({n} of {of} samples)" for name, (n, of) in lost.items())
    return f"the clock of {which} jumps away from the IMU's: those samples are not used"


def epochs(t: np.ndarray) -> np.ndarray:
    """Per sample (file order), how many times the clock restarted before it (a step back of more than
    :data:`RESET_S`)."""
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        return np.zeros(t.size, dtype=int)
    back = np.concatenate(([False], np.diff(t) < -RESET_S))
    return np.cumsum(back)


def continuous_stretch(t: np.ndarray, path: str = "") -> Stretch:
    """The longest continuous stretch of the reference stream's raw times ``t`` (s, file order), see the module
    docstring; InputError (exit 2) when even it spans more than :data:`~vinecli.specs.limits.MAX_LOG_SPAN_S`."""
    t = np.asarray(t, dtype=float)
    ok = np.isfinite(t)
    t = t[ok]
    if t.size == 0:
        return Stretch(0, -np.inf, np.inf)
    ep = epochs(t)
    d = np.diff(t)
    cut = np.concatenate(([True], (d < -RESET_S) | (d > JUMP_S), [True]))
    starts = np.flatnonzero(cut[:-1])
    ends = np.append(starts[1:], t.size)  # exclusive
    spans = [(float(t[a:b].max() - t[a:b].min()), a, b) for a, b in zip(starts, ends, strict=True)]
    span, a, b = max(spans, key=lambda s: (s[0], -s[1]))
    if span > MAX_LOG_SPAN_S:
        raise InputError(f"the log's clock runs {span / 3600:.1f} h without a break: at most "
                         f"{MAX_LOG_SPAN_S / 3600:.0f} h (a flight log, not a logger left on)", path=path or None)
    lo, hi = float(t[a:b].min()), float(t[a:b].max())
    note = ""
    if len(spans) > 1:
        resets = int(ep[-1])
        jumps = len(spans) - 1 - resets
        what = ", ".join(x for x in (f"restarts {resets} time(s)" if resets else "",
                                      f"jumps {jumps} time(s) (largest {float(np.max(np.abs(d))):.3g} s)" if jumps else "")
                         if x)
        note = (f"the log's clock {what}: only its longest continuous stretch is used ({span:.1f} s of "
                f"{sum(s[0] for s in spans):.1f} s, samples {a}-{b - 1} of the IMU's {t.size})")
    return Stretch(int(ep[a]), lo, hi, note)
