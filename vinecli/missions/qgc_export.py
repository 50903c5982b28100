"""MissionSpec -> QGroundControl ``.plan``, through THE phase <-> mission-item converter
(:func:`vinecli.phase_items.phases_to_items`, float-degree positions): the items the PX4 bridge uploads, the sprayer
on DO_SET_ACTUATOR (set 1, p1 = flow / the nozzle maximum), spray phases as THE spray plan with the sprayer on over
the rows only, the mission's geofence as the plan's inclusion polygon (and its distance limit as a circle about
home). One ``.plan`` per sortie of a planned job: :func:`sortie_plan` (:func:`vinecli.phase_items.sortie_to_items`).
Latitude/longitude come from the world's georeference (:func:`~vinecli.mavlink.mission_items.item_xy`), written
with 8 decimals (~1 mm); :mod:`vinecli.missions.qgc_import` reads them back.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from vinecli.geo import GeoOrigin
from vinecli.mavlink.mission_items import MissionItem, item_xy
from vinecli.missions.qgc_format import DEFAULT_NOZZLE_MAX_FLOW_LPS
from vinecli.phase_items import (
    DO_SET_ACTUATOR,
    ItemPlan,
    PlanContext,
    fence_items,
    phases_to_items,
    sortie_to_items,
)
from vinecli.rows.plan import PATH_ACCEL_MPS2, Leg
from vinecli.specs.mission import GeofenceSpec, MissionSpec

__all__ = ["export_plan", "plan_document", "sortie_plan"]

_FIRMWARE = "a QGroundControl .plan"


def _plan_context(origin: GeoOrigin, home_enu: tuple[float, float, float], nozzle_max_flow_lps: float, *,
                  rows_enu: Sequence[Sequence[tuple[float, float]]] = (), accel_mps2: float = PATH_ACCEL_MPS2,
                  surface: Callable[[float, float], float] | None = None) -> PlanContext:
    return PlanContext(origin=origin, home_enu=home_enu, vine_rows_enu=rows_enu, terrain_height=surface,
                       nozzle_max_flow_lps=nozzle_max_flow_lps, accel_mps2=accel_mps2, firmware=_FIRMWARE,
                       degrees=True)


def export_plan(
    mission: MissionSpec,
    origin: GeoOrigin,
    home_enu: tuple[float, float, float] = (0.0, 0.0, 0.0),
    *,
    rows_enu: Sequence[Sequence[tuple[float, float]]] = (),
    nozzle_max_flow_lps: float = DEFAULT_NOZZLE_MAX_FLOW_LPS,
    accel_mps2: float = PATH_ACCEL_MPS2,
    surface: Callable[[float, float], float] | None = None,
) -> dict[str, Any]:
    """A MissionSpec -> .plan JSON (dict). Spray phases fly ``rows_enu`` (the world's rows) or their own, planned
    by :func:`~vinecli.rows.plan.plan_rows` (a pass per row, nearest first, headland turns for ``accel_mps2``,
    clipped to the mission's geofence with a 1 m margin); with ``surface`` (ENU z of the DSM surface, m) the spray
    waypoints follow it. SpecError for phases a .plan cannot carry (open loop, ``until: empty``, refill)."""
    ctx = _plan_context(origin, home_enu, nozzle_max_flow_lps, rows_enu=rows_enu, accel_mps2=accel_mps2,
                        surface=surface)
    gf = mission.geofence
    return plan_document(phases_to_items(mission, ctx, sprayer=DO_SET_ACTUATOR), origin, home_enu,
                         fence_radius_m=gf.max_horizontal_distance_m if gf is not None else None)


# parameters: keyword-only options, each with its default (the plan's flight settings: height, speed, flow, take-off, terrain, fence); a caller names the ones it sets
def sortie_plan(legs: Sequence[Leg], origin: GeoOrigin, home_enu: tuple[float, float, float], *, height_m: float,
                speed_mps: float, flow_lps: float, nozzle_max_flow_lps: float, takeoff_m: float,
                surface: Callable[[float, float], float] | None = None,
                fence_enu: Sequence[tuple[float, float]] | None = None) -> dict[str, Any]:
    """One sortie as a ``.plan``: take-off at home, transit to the first row, the legs, return to launch."""
    ctx = _plan_context(origin, home_enu, nozzle_max_flow_lps, surface=surface)
    plan = sortie_to_items(legs, ctx, sprayer=DO_SET_ACTUATOR, takeoff_m=takeoff_m, height_m=height_m,
                           speed_mps=speed_mps, flow_lps=flow_lps)
    if fence_enu:
        plan.fence = fence_items(GeofenceSpec(polygon_enu=list(fence_enu)), origin, degrees=True)
    return plan_document(plan, origin, home_enu)


def _param(v: float) -> float | None:
    """A .plan parameter: NaN (unchanged / none) is JSON null."""
    return None if isinstance(v, float) and math.isnan(v) else v


def _plan_item(it: MissionItem, seq: int) -> dict[str, Any]:
    """One QGC SimpleItem: params 1-4, latitude, longitude (8 decimals), altitude."""
    lat, lon = (round(it.x, 8), round(it.y, 8)) if isinstance(it.x, float) else (it.x, it.y)
    params = [_param(p) for p in (it.param1, it.param2, it.param3, it.param4, lat, lon, it.z)]
    return {"type": "SimpleItem", "command": it.command, "frame": it.frame, "params": params,
            "autoContinue": bool(it.autocontinue), "doJumpId": seq}


def plan_document(plan: ItemPlan, origin: GeoOrigin, home_enu: tuple[float, float, float], *,
                  fence_radius_m: float | None = None) -> dict[str, Any]:
    """The ``.plan`` JSON of converted items: planned home, the mission items, the fence items as an inclusion
    polygon, ``fence_radius_m`` as an inclusion circle about home."""
    hlat, hlon = (round(v, 8) for v in item_xy(origin, home_enu[0], home_enu[1], degrees=True))
    doc: dict[str, Any] = {
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
            "items": [_plan_item(it, k + 1) for k, it in enumerate(plan.items)],
        },
        "geoFence": {"version": 2, "polygons": [], "circles": []},
        "rallyPoints": {"version": 2, "points": []},
    }
    if plan.fence:
        doc["geoFence"]["polygons"].append(
            {"polygon": [[round(it.x, 8), round(it.y, 8)] for it in plan.fence], "inclusion": True, "version": 1})
    if fence_radius_m:
        doc["geoFence"]["circles"].append(
            {"circle": {"center": [hlat, hlon], "radius": fence_radius_m}, "inclusion": True, "version": 1})
    return doc
