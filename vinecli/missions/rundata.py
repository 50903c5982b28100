"""The data of a finished run that checks and metrics read: time series, events, scalar metrics,
and the world facts (:class:`MetricContext`); time references ("liftoff+2", "phase_end:1") resolve here.
Time in s from the run start; columns SI with the frame in the name."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.rows.detect import Polyline


@dataclass(frozen=True)
class MetricContext:
    """World facts metrics need: gravity (m/s², positive) and the rows (ENU polylines, m)."""

    gravity: float = STANDARD_GRAVITY
    rows_enu: Sequence[Polyline] = field(default_factory=tuple)
    wind_period_s: float | None = None



_REF_RE = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)(?::(\d+))?\s*(?:([+-])\s*(\d+(?:\.\d*)?|\.\d+))?\s*$")
_EVENT_METRIC = {"liftoff": "liftoff_s", "touchdown": "touchdown_s", "tank_empty": "tank_empty_s"}


class EventMissing(LookupError):
    """A time reference names an event that did not happen in this run."""


def parse_time_ref(ref: str) -> tuple[str, int | None, float]:
    """``"liftoff-1.5"`` -> ("liftoff", None, -1.5); ``"phase:2"`` -> ("phase", 2, 0.0).

    Raises ValueError with a readable message for malformed references.
    """
    m = _REF_RE.match(ref)
    if not m:
        raise ValueError(f"bad time reference {ref!r} (expected e.g. 'liftoff-1.0', 'end-5', 'phase:2')")
    name, idx, sign, off = m.groups()
    if name in ("phase", "phase_end") and idx is None:
        raise ValueError(f"bad time reference {ref!r}: {name} needs an index, e.g. '{name}:1'")
    if idx is not None and name not in ("phase", "phase_end"):
        raise ValueError(f"bad time reference {ref!r}: only phase/phase_end take ':N'")
    offset = float(off) if off else 0.0
    if sign == "-":
        offset = -offset
    return name, (int(idx) if idx is not None else None), offset


@dataclass
class RunData:
    """What checks and metrics see of a run.

    ``timeseries``: columns (docs/architecture.md), each a 1-D array sampled at ``t_s``;
    ``events``: (t_s, kind) pairs; ``status``: final status name; ``metrics``: scalars the
    simulator reported; ``context``: world/vehicle facts metrics need (see
    :class:`vinecli.missions.metrics.MetricContext`).
    """

    timeseries: Mapping[str, np.ndarray]
    events: Sequence[tuple[float, str]] = ()
    status: str = "completed"
    metrics: Mapping[str, float] = field(default_factory=dict)
    context: MetricContext | None = None
    #: results derived once per run and shared by several metrics (not part of the run's data)
    cache: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def t(self) -> np.ndarray:
        return np.asarray(self.timeseries["t_s"], dtype=float)

    def column(self, name: str) -> np.ndarray:
        """A column as float array; KeyError if absent."""
        return np.asarray(self.timeseries[name], dtype=float)

    def has(self, name: str) -> bool:
        return name in self.timeseries

    def resolve_time(self, ref: float | int | str) -> float:
        """Seconds from the run start for a number or a time reference; EventMissing if it did not happen."""
        if isinstance(ref, (int, float)):
            return float(ref)
        name, idx, offset = parse_time_ref(ref)
        t = self.t
        if name == "start":
            base = float(t[0]) if len(t) else 0.0
        elif name == "end":
            base = float(t[-1]) if len(t) else 0.0
        elif name in ("phase", "phase_end"):
            if not self.has("phase_index"):
                raise EventMissing(f"{ref}: the run has no phase_index column")
            ph = self.column("phase_index")
            sel = np.flatnonzero(ph == idx)
            if sel.size == 0:
                raise EventMissing(f"{ref}: phase {idx} was never reached")
            base = float(t[sel[0]] if name == "phase" else t[sel[-1]])
        else:
            base = self.event_time(name)
        return base + offset

    def event_time(self, kind: str) -> float:
        """Time of the first event of ``kind`` (events first, then the simulator's ``<kind>_s`` metric).

        The simulator settles the vehicle before t = 0 and reports a lift-off only with the rotors
        carrying the vehicle, so the first ``liftoff`` is the take-off.
        """
        times = sorted(float(te) for te, k in self.events if k == kind)
        if times:
            return times[0]
        key = _EVENT_METRIC.get(kind, f"{kind}_s")
        v = self.metrics.get(key)
        if v is not None and np.isfinite(v):
            return float(v)
        raise EventMissing(f"event '{kind}' did not happen in this run")

    def window_mask(self, window: tuple[float, float] | None) -> np.ndarray:
        t = self.t
        if window is None:
            return np.ones(t.shape, dtype=bool)
        return (t >= window[0] - 1e-9) & (t <= window[1] + 1e-9)
