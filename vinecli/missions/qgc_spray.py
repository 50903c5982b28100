"""One QGroundControl ``.plan`` per sortie (take-off, the sortie's rows, return to launch), as PX4 and
QGC fly them; the waypoints and sprayer switches are :func:`vinecli.phase_items.spray_legs.leg_actions`."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from vinecli.geo import GeoOrigin
from vinecli.phase_items.spray_legs import leg_actions
from vinecli.rows.plan import Leg

__all__ = ["sortie_plan"]

def sortie_plan(legs: Sequence[Leg], origin: GeoOrigin, home_enu: tuple[float, float, float], *, height_m: float,
                speed_mps: float, flow_lps: float, nozzle_max_flow_lps: float, takeoff_m: float,
                surface: Callable[[float, float], float] | None = None,
                fence_enu: Sequence[tuple[float, float]] | None = None) -> dict[str, Any]:
    """One sortie as a ``.plan``: take-off at home, transit to the first row, the legs, return to launch."""
    from vinecli.missions.qgc_export import PlanItems, plan_document
    from vinecli.missions.qgc_format import (
        DO_CHANGE_SPEED,
        DO_SET_ACTUATOR,
        FRAME_GLOBAL_RELATIVE_ALT,
        FRAME_MISSION,
        NAV_RTL,
        NAV_TAKEOFF,
        NAV_WAYPOINT,
    )

    built = PlanItems(origin)
    items, ll, add = built.items, built.ll, built.add
    home_z = surface(home_enu[0], home_enu[1]) if surface is not None else 0.0

    lat, lon = ll(home_enu[0], home_enu[1])
    add(NAV_TAKEOFF, FRAME_GLOBAL_RELATIVE_ALT, [0, 0, 0, None, lat, lon, takeoff_m])
    add(DO_CHANGE_SPEED, FRAME_MISSION, [1, speed_mps, -1, 0, 0, 0, 0])
    first = legs[0].points[0]
    transit = Leg([(home_enu[0], home_enu[1]), first], False, None, "transit")
    for kind, a, b, c in leg_actions([transit, *legs], height_m=height_m, flow_lps=flow_lps, surface=surface,
                                     home_z=home_z):
        if kind == "wp":
            la, lo = ll(a, b)
            add(NAV_WAYPOINT, FRAME_GLOBAL_RELATIVE_ALT, [0, 0, 0, None, la, lo, c])
        else:
            add(DO_SET_ACTUATOR, FRAME_MISSION, [round(a / nozzle_max_flow_lps, 6), None, None, None, None, None, 1])
    add(NAV_RTL, FRAME_MISSION, [0, 0, 0, 0, 0, 0, 0])
    return plan_document(items, origin, home_enu, fence_enu=fence_enu)
