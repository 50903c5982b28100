"""MissionSpec -> QGroundControl ``.plan``: the inverse of :mod:`vinecli.missions.qgc_import`. Spray phases are
expanded into the operator plan of :mod:`vinecli.rows.plan` with DO_SET_ACTUATOR on/off around each row; one
``.plan`` per sortie: :func:`vinecli.missions.qgc_spray.sortie_plan`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from vinecli.errors import SpecError
from vinecli.geo import GeoOrigin
from vinecli.missions.qgc_format import (
    DEFAULT_NOZZLE_MAX_FLOW_LPS,
    DO_CHANGE_SPEED,
    DO_SET_ACTUATOR,
    FRAME_GLOBAL_RELATIVE_ALT,
    FRAME_MISSION,
    NAV_LAND,
    NAV_LOITER_TIME,
    NAV_RTL,
    NAV_TAKEOFF,
    NAV_WAYPOINT,
    plan_item,
)
from vinecli.missions.qgc_geometry import latlon_of
from vinecli.specs.mission import (
    GotoPhase,
    HoldPhase,
    LandPhase,
    MissionSpec,
    RtlPhase,
    SprayerPhase,
    SprayPhase,
    TakeoffPhase,
    WaypointsPhase,
)

__all__ = ["PlanItems", "export_plan", "plan_document"]


class PlanItems:
    """Mission items under construction: numbered in order, ENU points as rounded latitude/longitude."""

    def __init__(self, origin: GeoOrigin) -> None:
        self.origin = origin
        self.items: list[dict[str, Any]] = []

    def ll(self, x: float, y: float) -> tuple[float, float]:
        """(lat, lon) in degrees, 8 decimals, of the ENU point (x, y) m."""
        return latlon_of(self.origin, x, y)

    def add(self, command: int, frame: int, params: Sequence[float | None]) -> None:
        """Append one item with the next sequence number."""
        self.items.append(plan_item(command, frame, params, len(self.items) + 1))



def plan_document(items: list[dict[str, Any]], origin: GeoOrigin, home_enu: tuple[float, float, float], *,
                  fence_enu: Sequence[tuple[float, float]] | None = None,
                  fence_radius_m: float | None = None) -> dict[str, Any]:
    """The ``.plan`` JSON around mission items: planned home, geofence polygon / circle about home."""
    def ll(x: float, y: float) -> tuple[float, float]:
        return latlon_of(origin, x, y)

    hlat, hlon = ll(home_enu[0], home_enu[1])
    plan: dict[str, Any] = {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "QGroundControl",
        "mission": {
            "version": 2,
            "firmwareType": 12,
            "vehicleType": 2,
            "cruiseSpeed": 15,
            "hoverSpeed": 2,
            "globalPlanAltitudeMode": 1,
            "plannedHomePosition": [hlat, hlon, round(origin.alt + home_enu[2], 3)],
            "items": items,
        },
        "geoFence": {"version": 2, "polygons": [], "circles": []},
        "rallyPoints": {"version": 2, "points": []},
    }
    if fence_enu:
        plan["geoFence"]["polygons"].append(
            {"polygon": [list(ll(x, y)) for x, y in fence_enu], "inclusion": True, "version": 1})
    if fence_radius_m:
        plan["geoFence"]["circles"].append(
            {"circle": {"center": [hlat, hlon], "radius": fence_radius_m}, "inclusion": True, "version": 1})
    return plan


def export_plan(
    mission: MissionSpec,
    origin: GeoOrigin,
    home_enu: tuple[float, float, float] = (0.0, 0.0, 0.0),
    *,
    rows_enu: Sequence[Sequence[tuple[float, float]]] = (),
    nozzle_max_flow_lps: float = DEFAULT_NOZZLE_MAX_FLOW_LPS,
    accel_mps2: float = 1.5,
    surface: Callable[[float, float], float] | None = None,
) -> dict[str, Any]:
    """A MissionSpec -> .plan JSON (dict). Spray phases become the operator plan of
    :func:`~vinecli.rows.plan.plan_rows` over ``rows_enu`` (or the phase's explicit rows): nearest
    row first, headland turns for ``accel_mps2``, rows clipped to the mission's geofence with a 1 m margin,
    DO_SET_ACTUATOR (p1 = flow / nozzle_max_flow_lps) on over each row and off after it. With ``surface``
    (ENU z of the DSM surface) the spray waypoints follow it (see :mod:`vinecli.missions.qgc_spray`)."""
    from vinecli.phase_items.spray_legs import leg_actions
    from vinecli.rows.plan import plan_rows

    built = PlanItems(origin)
    items, ll, add = built.items, built.ll, built.add
    cur = [home_enu[0], home_enu[1], 0.0]
    home_z = surface(home_enu[0], home_enu[1]) if surface is not None else 0.0

    def wp(x: float, y: float, h: float) -> None:
        lat, lon = ll(x, y)
        add(NAV_WAYPOINT, FRAME_GLOBAL_RELATIVE_ALT, [0, 0, 0, None, lat, lon, round(h, 3)])
        cur[:] = [x, y, h]

    def actuator(flow: float) -> None:
        add(DO_SET_ACTUATOR, FRAME_MISSION, [round(flow / nozzle_max_flow_lps, 6), None, None, None, None, None, 1])

    gf = mission.geofence
    fence = gf.polygon_enu if gf is not None and gf.polygon_enu else None
    for i, ph in enumerate(mission.phases):
        if isinstance(ph, TakeoffPhase):
            lat, lon = ll(cur[0], cur[1])
            add(NAV_TAKEOFF, FRAME_GLOBAL_RELATIVE_ALT, [0, 0, 0, None, lat, lon, ph.altitude_agl_m])
            cur[2] = ph.altitude_agl_m
        elif isinstance(ph, HoldPhase):
            lat, lon = ll(cur[0], cur[1])
            add(NAV_LOITER_TIME, FRAME_GLOBAL_RELATIVE_ALT, [ph.duration_s, 0, 0, None, lat, lon, cur[2]])
        elif isinstance(ph, GotoPhase):
            if ph.speed_mps:
                add(DO_CHANGE_SPEED, FRAME_MISSION, [1, ph.speed_mps, -1, 0, 0, 0, 0])
            wp(ph.position_enu[0], ph.position_enu[1], ph.altitude_agl_m if ph.altitude_agl_m is not None else cur[2])
        elif isinstance(ph, WaypointsPhase):
            add(DO_CHANGE_SPEED, FRAME_MISSION, [1, ph.speed_mps, -1, 0, 0, 0, 0])
            if ph.flow_lps is not None:
                actuator(ph.flow_lps)
            for x, y, h in ph.waypoints:
                wp(x, y, h)
        elif isinstance(ph, SprayerPhase):
            actuator(ph.flow_lps)
        elif isinstance(ph, SprayPhase):
            if ph.rows == "world":
                rows = [list(r) for r in rows_enu]
            elif ph.rows and isinstance(ph.rows[0], int):
                rows = [list(rows_enu[int(k)]) for k in ph.rows]  # type: ignore[arg-type]
            else:
                rows = [[tuple(p) for p in r] for r in ph.rows]  # type: ignore[union-attr]
            if not rows:
                raise SpecError(f"phases.{i}: spray phase has no rows to export", path=mission.name)
            plan = plan_rows(rows, (cur[0], cur[1]), speed_mps=ph.speed_mps, accel_mps2=accel_mps2, fence_enu=fence)
            if not plan.legs:
                raise SpecError(f"phases.{i}: no rows left inside the geofence", path=mission.name)
            add(DO_CHANGE_SPEED, FRAME_MISSION, [1, ph.speed_mps, -1, 0, 0, 0, 0])
            for kind, a, b, c in leg_actions(plan.legs, height_m=ph.height_agl_m, flow_lps=ph.flow_lps,
                                             surface=surface, home_z=home_z):
                if kind == "wp":
                    wp(a, b, c)
                else:
                    actuator(a)
        elif isinstance(ph, LandPhase):
            lat, lon = ll(cur[0], cur[1])
            add(NAV_LAND, FRAME_GLOBAL_RELATIVE_ALT, [0, 0, 0, None, lat, lon, 0])
        elif isinstance(ph, RtlPhase):
            add(NAV_RTL, FRAME_MISSION, [0, 0, 0, 0, 0, 0, 0])
        else:
            raise SpecError(f"phases.{i}: {ph.type!r} phases have no .plan equivalent", path=mission.name)
    return plan_document(items, origin, home_enu, fence_enu=fence,
                         fence_radius_m=gf.max_horizontal_distance_m if gf is not None else None)
