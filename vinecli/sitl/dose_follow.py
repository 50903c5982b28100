"""What a firmware does with segment rates (docs/dose.md §5), said once per run as the event ``dose_follow``
{autopilot, method, limits, plan}: the run's ``summary.json`` ``as_applied.follows`` and the report quote it.

* PX4 (:data:`PX4_METHOD`): mission items, a DO_SET_ACTUATOR value per rate piece at its first waypoint, moved
  ``speed x tau`` earlier for the pump's lag; PX4 does not scale the pump with ground speed.
* ArduPilot (:data:`ARDUPILOT_METHOD`): DO_SPRAYER on and off at the passes and gaps, SPRAY_PUMP_RATE set by the
  ground station in flight (:mod:`vinecli.sitl.ardupilot.pump_rates`).
"""

from __future__ import annotations

from typing import Any

__all__ = ["ARDUPILOT_METHOD", "PX4_METHOD", "follow_event"]

PX4_METHOD = ("DO_SET_ACTUATOR per rate piece: a mission item at each piece's first waypoint, moved speed x tau earlier "
              "for the pump's lag, sets the pump output of the piece's rate at the phase's speed")
PX4_LIMITS = ["rate pieces shorter than 6 m are joined at their mean rate: PX4 v1.15 slows down at waypoints closer "
              "than that (4 m pieces: 0.35-0.55 m/s at each, with or without the DO_SET_ACTUATOR items)",
              "no speed scaling: the pump output is fixed per piece, so where PX4 flies slower or faster than planned "
              "(waypoints, turns, wind) the rate moves with it",
              "the output switches when PX4 accepts the waypoint (its acceptance radius), not at the piece's start",
              "pieces above the pump's range are not flown slower: one speed per mission"]
ARDUPILOT_METHOD = ("SPRAY_PUMP_RATE set by PARAM_SET from the ground station as the vehicle reaches each rate piece "
                    "(its GLOBAL_POSITION_INT, lead {lead_s:.2f} s), DO_SPRAYER on and off at the passes and gaps; "
                    "AC_Sprayer scales the pump with ground speed")
ARDUPILOT_LIMITS = ["AC_Sprayer recomputes the pump at 3 Hz: a rate change lands up to 0.33 s late",
                    "the rate follows the ground station's link: a lost link keeps the last rate",
                    "pieces above the pump's range are not flown slower: one speed per mission; SPRAY_PUMP_MIN holds "
                    "the pump at the nozzles' minimum"]


def follow_event(autopilot: str, rate_paths: dict[int, tuple[Any, Any]], *, lead_s: float = 0.0
                 ) -> tuple[str, str, dict[str, Any]] | None:
    """(kind, message, data) of the ``dose_follow`` event of a firmware mission with segment rates (None
    without): the method, its limits and the rate path's summary (pieces, rate range, pieces out of range)."""
    if not rate_paths:
        return None
    _, rp = rate_paths[min(rate_paths)]
    plan = rp.summary()
    if autopilot == "px4":
        method, limits = PX4_METHOD, PX4_LIMITS
    else:
        method, limits = ARDUPILOT_METHOD.format(lead_s=lead_s), ARDUPILOT_LIMITS
    limits = [*limits, *(f"{n['kind']}: {n.get('pieces', '')} pieces, {n.get('length_m', '')} m" for n in
                         plan["out_of_range"] if n["kind"] != "broadcast")]
    return ("dose_follow", f"{autopilot}: segment rates by {method.split(':')[0].split(' (')[0]}",
            {"autopilot": autopilot, "method": method, "limits": limits, "plan": plan})
