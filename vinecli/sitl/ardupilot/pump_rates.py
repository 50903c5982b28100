"""Segment rates flown by ArduPilot as an operator's ground station can: SPRAY_PUMP_RATE set by PARAM_SET as the
vehicle reaches each rate piece (docs/dose.md §5).

ArduCopter's sprayer (AC_Sprayer) has one pump rate, ``SPRAY_PUMP_RATE`` (% of the pump's output per m/s of ground
speed): ``pump % = SPRAY_PUMP_RATE x speed`` (at least SPRAY_PUMP_MIN %), recomputed by its ``update`` at 3 Hz
(ArduCopter's scheduler table); DO_SPRAYER in the mission switches it on and off. MAVLink has no command for a
rate per location. So the mission switches the sprayer off and on at the gaps (mission items), and the ground
station (vinecli's MAVLink client, :class:`~vinecli.sitl.ardupilot.client.ArdupilotClient`) watches the vehicle's
own GLOBAL_POSITION_INT (10 Hz) and sends ``PARAM_SET SPRAY_PUMP_RATE`` = ``100 x litres per metre / the pump's
maximum flow`` of the next piece when the vehicle is within ``ground speed x lead_s`` of its start along the path:
``lead_s`` = the pump's rise time constant + half the sprayer's update period + the link's delay
(:data:`LINK_DELAY_S`). What it cannot do: follow a rate faster than the 3 Hz update and the position stream allow,
slow down where the pump's range cannot deliver a rate (the mission's speed is fixed at upload), or close a gap
shorter than the waypoints' switching allows.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

__all__ = ["LINK_DELAY_S", "SPRAYER_UPDATE_HZ", "PumpRateSchedule", "RateChange", "lead_time_s"]

#: ArduCopter runs AC_Sprayer::update at 3 Hz (its scheduler table)
SPRAYER_UPDATE_HZ = 3.0
#: position report to PARAM_SET taking effect: the 10 Hz stream's half period and the ordered inbox's delivery, s
LINK_DELAY_S = 0.13
#: a change is for the vehicle when it is this close to the path's line there, m
_CROSS_M = 1.5


def lead_time_s(tau_up_s: float) -> float:
    """How long before a piece's start the ground station sets its rate, s (module docstring)."""
    return tau_up_s + 0.5 / SPRAYER_UPDATE_HZ + LINK_DELAY_S


@dataclass(frozen=True)
class RateChange:
    """A piece's start along the path (world ENU m), the path's unit direction there, the SPRAY_PUMP_RATE it needs
    (% per m/s) and its prescribed rate (L/ha)."""

    x: float
    y: float
    dx: float
    dy: float
    pump_rate: float
    rate_lpha: float


@dataclass
class PumpRateSchedule:
    """The rate changes of a mission in flight order and which is next (module docstring)."""

    changes: list[RateChange]
    lead_s: float
    next_i: int = 0
    sent: list[tuple[float, int, float]] = field(default_factory=list)  # (t s, change index, SPRAY_PUMP_RATE)

    @classmethod
    def from_path(cls, points: Sequence[tuple[float, float]], flows: Sequence[float], rates: Sequence[float],
                  max_flow_lps: float, lead_s: float) -> PumpRateSchedule:
        """The changes along a rate path (:class:`~vinecli.rows.rate_path.RatePath` points, litres per metre and
        L/ha per segment): each sprayed piece whose litres per metre differ from the last set."""
        out: list[RateChange] = []
        last = math.nan
        for i, f in enumerate(flows):
            if f <= 0.0 or f == last:
                continue
            (ax, ay), (bx, by) = points[i], points[i + 1]
            n = math.hypot(bx - ax, by - ay) or 1.0
            out.append(RateChange(ax, ay, (bx - ax) / n, (by - ay) / n, round(100.0 * f / max_flow_lps, 4), rates[i]))
            last = f
        return cls(out, lead_s)

    def due(self, t_s: float, x: float, y: float, vx: float, vy: float) -> RateChange | None:
        """The change to send now for a vehicle at (x, y) moving at (vx, vy) (world ENU m, m/s), else None: the
        next one once the vehicle is within speed x ``lead_s`` of it along the path (or past it)."""
        if self.next_i >= len(self.changes):
            return None
        c = self.changes[self.next_i]
        ex, ey = x - c.x, y - c.y
        along = ex * c.dx + ey * c.dy
        cross = abs(ex * c.dy - ey * c.dx)
        if cross > _CROSS_M or along < -math.hypot(vx, vy) * self.lead_s:
            return None
        self.sent.append((t_s, self.next_i, c.pump_rate))
        self.next_i += 1
        return c
