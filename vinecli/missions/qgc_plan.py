"""QGroundControl ``.plan`` files (JSON) <-> :class:`MissionSpec`.

Import (:func:`import_plan`): simple items are mapped in order onto mission phases; survey /
corridor items are flattened from ``TransectStyleComplexItem.Items`` (QGC stores the generated
waypoints there); ``geoFence`` becomes the mission's geofence. Latitude/longitude go to the
world's ENU frame through its :class:`~vinecli.geo.GeoOrigin`; altitudes become heights
above home (frame 3 = relative already; frame 0 = AMSL minus the home altitude; frame 10 =
terrain altitude, taken as above home). Unsupported items raise a SpecError naming the item
index (``mission.items[4]`` or ``mission.items[2].TransectStyleComplexItem.Items[7]``).

=====  ======================  ====================================================
cmd    MAVLink                 phase
=====  ======================  ====================================================
22     NAV_TAKEOFF             takeoff to the item's altitude
16     NAV_WAYPOINT            consecutive waypoints -> one ``waypoints`` phase; p1 > 0 adds a hold
178    DO_CHANGE_SPEED         speed (p2, m/s) of the following waypoints
187    DO_SET_ACTUATOR         sprayer: p1 = fraction of the nozzle's maximum flow (<= 0 off, NaN unchanged)
183    DO_SET_SERVO            sprayer (ArduPilot style): p2 PWM 1000..2000 µs -> 0..1 of max flow
216    DO_SPRAYER              sprayer (ArduPilot): p1 1 on (at ``spray_flow_lps``), 0 off
19     NAV_LOITER_TIME         goto the item's position, hold p1 s
93     NAV_DELAY               hold p1 s
21     NAV_LAND                goto the item's position (if given), land
20     NAV_RETURN_TO_LAUNCH    rtl
=====  ======================  ====================================================

Export (:func:`export_plan`) writes the inverse mapping (spray phases are expanded into the
operator plan of :mod:`vinecli.rows.plan` with DO_SET_ACTUATOR on/off around each row;
one ``.plan`` per sortie: :func:`vinecli.missions.qgc_spray.sortie_plan`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from vinecli.errors import InputError, SpecError
from vinecli.geo import GeoOrigin
from vinecli.inputs import note_input, read_input_text, reading_inputs
from vinecli.names import check_name, name_from
from vinecli.outputs import check_output_file, write_text_atomic
from vinecli.specs import format_validation_error
from vinecli.specs.limits import MAX_DURATION_S
from vinecli.specs.mission import (
    GeofenceSpec,
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
from vinecli.specs.vehicle import VehicleSpec

#: the flow (L/s) an actuator value of 1.0 stands for when the vehicle has no tank
DEFAULT_NOZZLE_MAX_FLOW_LPS = 0.1

NAV_WAYPOINT, NAV_LOITER_TIME, NAV_RTL, NAV_LAND, NAV_TAKEOFF, NAV_DELAY = 16, 19, 20, 21, 22, 93
DO_CHANGE_SPEED, DO_SET_SERVO, DO_SET_ACTUATOR, DO_SPRAYER = 178, 183, 187, 216
FRAME_GLOBAL, FRAME_MISSION, FRAME_GLOBAL_RELATIVE_ALT, FRAME_TERRAIN = 0, 2, 3, 10
SUPPORTED = {NAV_WAYPOINT, NAV_LOITER_TIME, NAV_RTL, NAV_LAND, NAV_TAKEOFF, NAV_DELAY, DO_CHANGE_SPEED,
             DO_SET_SERVO, DO_SET_ACTUATOR, DO_SPRAYER}


# ---------------------------------------------------------------- the .plan model (fields we use)
class _Loose(BaseModel):
    model_config = ConfigDict(extra="allow")


class SimpleItem(_Loose):
    type: Literal["SimpleItem"] = "SimpleItem"
    command: int
    frame: int = FRAME_GLOBAL_RELATIVE_ALT
    params: list[float | None] = Field(min_length=7, max_length=7)
    autoContinue: bool = True
    doJumpId: int | None = None

    def p(self, i: int) -> float:
        """Param i (1-based, 1..7); JSON null -> NaN."""
        v = self.params[i - 1]
        return math.nan if v is None else float(v)


class TransectStyle(_Loose):
    Items: list[SimpleItem] = Field(default_factory=list)


class ComplexItem(_Loose):
    type: Literal["ComplexItem"] = "ComplexItem"
    complexItemType: str
    TransectStyleComplexItem: TransectStyle | None = None


class PlanMission(_Loose):
    version: int = 2
    firmwareType: int = 12
    vehicleType: int = 2
    hoverSpeed: float = 5.0
    cruiseSpeed: float = 15.0
    plannedHomePosition: list[float] = Field(min_length=3, max_length=3)
    items: list[SimpleItem | ComplexItem] = Field(min_length=1)


class FenceCircle(_Loose):
    center: list[float] = Field(min_length=2, max_length=2)
    radius: float = Field(gt=0)


class FencePolygon(_Loose):
    polygon: list[list[float]] = Field(min_length=3)
    inclusion: bool = True
    version: int = 1


class FenceCircleItem(_Loose):
    circle: FenceCircle
    inclusion: bool = True
    version: int = 1


class GeoFence(_Loose):
    version: int = 2
    polygons: list[FencePolygon] = Field(default_factory=list)
    circles: list[FenceCircleItem] = Field(default_factory=list)


class Plan(_Loose):
    fileType: Literal["Plan"]
    version: int = 1
    groundStation: str = "QGroundControl"
    mission: PlanMission
    geoFence: GeoFence | None = None
    rallyPoints: dict[str, Any] | None = None


def read_plan(path: Path | str) -> Plan:
    """Parse and validate a .plan file; SpecError naming the file and field."""
    path = Path(path)
    try:
        data = json.loads(read_input_text(path, "file"))
    except InputError as exc:
        raise SpecError(exc.problem, path=path) from None
    except json.JSONDecodeError as exc:
        raise SpecError(f"invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}", path=path) from None
    try:
        return Plan.model_validate(data)
    except ValidationError as exc:
        raise SpecError(format_validation_error(exc), path=path) from None


# ---------------------------------------------------------------- import
def import_plan(
    path: Path | str,
    origin: GeoOrigin,
    *,
    nozzle_max_flow_lps: float = DEFAULT_NOZZLE_MAX_FLOW_LPS,
    spray_flow_lps: float | None = None,
    name: str | None = None,
    home_alt_m: float | None = None,
) -> MissionSpec:
    """A .plan file -> MissionSpec in the ENU frame of ``origin``.

    ``nozzle_max_flow_lps`` scales DO_SET_ACTUATOR / DO_SET_SERVO values to L/s;
    ``spray_flow_lps`` is the flow of DO_SPRAYER "on" (default: half the maximum).
    ``home_alt_m`` (AMSL) for frame-0 altitudes: default the plan's planned home altitude.
    ``name``: the mission name (checked, InputError), default derived from the file name.
    A plan whose values the mission spec refuses (NaN, beyond :mod:`vinecli.specs.limits`) is a SpecError.
    """
    path = Path(path)
    name = check_name(name, "--name", path=path) if name is not None else name_from(path.stem)
    try:
        return _import_plan(path, origin, nozzle_max_flow_lps, spray_flow_lps, name, home_alt_m)
    except ValidationError as exc:
        raise SpecError(format_validation_error(exc), path=path) from None


def vehicle_nozzle_flow_lps(vehicle: VehicleSpec) -> float:
    """The flow (L/s) a .plan's actuator value 1.0 stands for on ``vehicle``: its nozzle's maximum
    (:data:`DEFAULT_NOZZLE_MAX_FLOW_LPS` without a tank)."""
    return vehicle.tank.nozzle_max_flow_lps if vehicle.tank is not None else DEFAULT_NOZZLE_MAX_FLOW_LPS


def import_plan_for_world(plan: Path | str, world: Path | str, out: Path | str, *, spray_flow_lps: float | None = None,
                          name: str | None = None, overwrite: bool = False) -> MissionSpec:
    """``vinecli plan import``: the .plan ``plan`` as a mission of the built world ``world`` (its geodetic origin,
    actuator values scaled to its vehicle's nozzle, see :func:`import_plan`), written to ``out`` as mission YAML
    (an existing ``out`` only with ``overwrite``; never an input: OutputError, exit 2)."""
    from vinecli.missions.spec_io import write_mission
    from vinecli.world import load_world

    with reading_inputs():
        note_input(plan, "plan")
        w = load_world(world)
        mission = import_plan(plan, w.origin, nozzle_max_flow_lps=vehicle_nozzle_flow_lps(w.vehicle),
                              spray_flow_lps=spray_flow_lps, name=name)
        check_output_file(Path(out), overwrite=overwrite)
        write_mission(out, mission)
    return mission


def _import_plan(path: Path, origin: GeoOrigin, nozzle_max_flow_lps: float, spray_flow_lps: float | None,
                 name: str, home_alt_m: float | None) -> MissionSpec:
    plan = read_plan(path)
    home = plan.mission.plannedHomePosition
    h_alt = float(home[2]) if home_alt_m is None else home_alt_m
    flat: list[tuple[str, SimpleItem]] = []
    for i, it in enumerate(plan.mission.items):
        if isinstance(it, SimpleItem):
            flat.append((f"mission.items[{i}]", it))
        else:
            ts = it.TransectStyleComplexItem
            if ts is None or not ts.Items:
                raise SpecError(f"mission.items[{i}]: complex item {it.complexItemType!r} has no "
                                "TransectStyleComplexItem.Items to flatten", path=path)
            flat += [(f"mission.items[{i}].TransectStyleComplexItem.Items[{j}]", s) for j, s in enumerate(ts.Items)]

    spray_on = spray_flow_lps if spray_flow_lps is not None else 0.5 * nozzle_max_flow_lps
    phases: list[Any] = []
    wps: list[tuple[float, float, float]] = []
    speed = float(plan.mission.hoverSpeed) if plan.mission.hoverSpeed > 0 else 2.0
    wp_speed = speed
    length = 0.0
    last_xy: tuple[float, float] = (0.0, 0.0)
    last_h = 0.0

    def flush() -> None:
        nonlocal wps
        if wps:
            phases.append(WaypointsPhase(waypoints=wps, speed_mps=wp_speed))
            wps = []

    def pos(where: str, it: SimpleItem, need_alt: bool = True) -> tuple[float, float, float] | None:
        lat, lon, alt = it.p(5), it.p(6), it.p(7)
        if math.isnan(lat) or math.isnan(lon) or (lat == 0.0 and lon == 0.0):
            return None
        if need_alt and math.isnan(alt):
            raise SpecError(f"{where}: altitude (param 7) is missing", path=path)
        e, n, _ = origin.geodetic_to_enu(lat, lon, origin.alt)
        if it.frame in (FRAME_GLOBAL_RELATIVE_ALT, FRAME_TERRAIN, FRAME_MISSION):
            h = alt
        elif it.frame == FRAME_GLOBAL:
            h = alt - h_alt
        else:
            raise SpecError(f"{where}: unsupported frame {it.frame} (use 0, 3 or 10)", path=path)
        return (e, n, h)

    for where, it in flat:
        c = it.command
        if c not in SUPPORTED:
            raise SpecError(f"{where}: unsupported command {c} (supported: {sorted(SUPPORTED)})", path=path)
        if c == NAV_WAYPOINT:
            p = pos(where, it)
            if p is None:
                raise SpecError(f"{where}: waypoint without a position", path=path)
            if wps and wp_speed != speed:
                flush()
            wp_speed = speed
            length += math.hypot(p[0] - last_xy[0], p[1] - last_xy[1])
            last_xy, last_h = (p[0], p[1]), p[2]
            wps.append(p)
            if it.p(1) > 0:
                flush()
                phases.append(HoldPhase(duration_s=it.p(1)))
            continue
        flush()
        if c == NAV_TAKEOFF:
            p = pos(where, it, need_alt=True)
            alt = p[2] if p is not None else it.p(7)
            if math.isnan(alt) or alt <= 0:
                raise SpecError(f"{where}: takeoff altitude must be > 0 m above home", path=path)
            phases.append(TakeoffPhase(altitude_agl_m=alt))
            last_h = alt
        elif c == DO_CHANGE_SPEED:
            if it.p(2) > 0:
                speed = it.p(2)
        elif c == DO_SET_ACTUATOR:
            v = it.p(1)
            if not math.isnan(v):
                phases.append(SprayerPhase(flow_lps=round(max(0.0, min(1.0, v)) * nozzle_max_flow_lps, 9)))
        elif c == DO_SET_SERVO:
            pwm = it.p(2)
            if math.isnan(pwm):
                raise SpecError(f"{where}: DO_SET_SERVO without a PWM value (param 2)", path=path)
            frac = max(0.0, min(1.0, (pwm - 1000.0) / 1000.0))
            phases.append(SprayerPhase(flow_lps=round(frac * nozzle_max_flow_lps, 9)))
        elif c == DO_SPRAYER:
            phases.append(SprayerPhase(flow_lps=spray_on if it.p(1) >= 0.5 else 0.0))
        elif c == NAV_LOITER_TIME:
            p = pos(where, it)
            if p is not None and (math.hypot(p[0] - last_xy[0], p[1] - last_xy[1]) > 0.5 or abs(p[2] - last_h) > 0.1):
                phases.append(GotoPhase(position_enu=(p[0], p[1]), altitude_agl_m=p[2], speed_mps=speed))
                length += math.hypot(p[0] - last_xy[0], p[1] - last_xy[1])
                last_xy, last_h = (p[0], p[1]), p[2]
            phases.append(HoldPhase(duration_s=max(it.p(1), 0.1)))
        elif c == NAV_DELAY:
            if not it.p(1) > 0:
                raise SpecError(f"{where}: NAV_DELAY needs a delay in seconds (param 1)", path=path)
            phases.append(HoldPhase(duration_s=it.p(1)))
        elif c == NAV_LAND:
            p = pos(where, it, need_alt=False)
            if p is not None and math.hypot(p[0] - last_xy[0], p[1] - last_xy[1]) > 0.5:
                phases.append(GotoPhase(position_enu=(p[0], p[1]), speed_mps=speed))
                length += math.hypot(p[0] - last_xy[0], p[1] - last_xy[1])
            phases.append(LandPhase())
        elif c == NAV_RTL:
            phases.append(RtlPhase())
    flush()
    if not phases:
        raise SpecError("mission.items: nothing to fly", path=path)
    holds = sum(p.duration_s for p in phases if isinstance(p, HoldPhase))
    est = length / max(speed, 0.5) + holds + 30.0 * sum(isinstance(p, (TakeoffPhase, LandPhase, RtlPhase))
                                                        for p in phases)
    geofence = _import_fence(plan.geoFence, origin, path) if plan.geoFence else None
    return MissionSpec(
        name=name,
        description=f"imported from {path.name}",
        phases=phases,
        geofence=geofence,
        max_duration_s=min(MAX_DURATION_S, round(max(60.0, 1.5 * est + 60.0), 1)),
    )


def _import_fence(fence: GeoFence, origin: GeoOrigin, path: Path) -> GeofenceSpec | None:
    polygon: list[tuple[float, float]] | None = None
    radius: float | None = None
    for i, poly in enumerate(fence.polygons):
        if not poly.inclusion:
            raise SpecError(f"geoFence.polygons[{i}]: exclusion polygons are not supported", path=path)
        if polygon is not None:
            raise SpecError(f"geoFence.polygons[{i}]: only one inclusion polygon is supported", path=path)
        pts = []
        for lat, lon in (tuple(v[:2]) for v in poly.polygon):
            e, n, _ = origin.geodetic_to_enu(lat, lon, origin.alt)
            pts.append((round(e, 4), round(n, 4)))
        polygon = pts
    for i, c in enumerate(fence.circles):
        if not c.inclusion:
            raise SpecError(f"geoFence.circles[{i}]: exclusion circles are not supported", path=path)
        e, n, _ = origin.geodetic_to_enu(c.circle.center[0], c.circle.center[1], origin.alt)
        if math.hypot(e, n) <= 1.0:  # a cylinder about home: PX4's GF_MAX_HOR_DIST
            radius = c.circle.radius if radius is None else min(radius, c.circle.radius)
        elif polygon is None:
            polygon = [(round(e + c.circle.radius * math.cos(a), 4), round(n + c.circle.radius * math.sin(a), 4))
                       for a in (2 * math.pi * k / 32 for k in range(32))]
        else:
            raise SpecError(f"geoFence.circles[{i}]: an off-home circle and a polygon cannot be combined", path=path)
    if polygon is None and radius is None:
        return None
    return GeofenceSpec(polygon_enu=polygon, max_horizontal_distance_m=radius)


# ---------------------------------------------------------------- export
def plan_item(command: int, frame: int, params: Sequence[float | None], seq: int) -> dict[str, Any]:
    """One QGC SimpleItem (NaN parameters become null)."""
    ps = [None if (p is None or (isinstance(p, float) and math.isnan(p))) else p for p in params]
    return {"type": "SimpleItem", "command": command, "frame": frame, "params": ps, "autoContinue": True,
            "doJumpId": seq}


class PlanItems:
    """Mission items under construction: numbered in order, ENU points as rounded latitude/longitude."""

    def __init__(self, origin: GeoOrigin) -> None:
        self.origin = origin
        self.items: list[dict[str, Any]] = []

    def ll(self, x: float, y: float) -> tuple[float, float]:
        """(lat, lon) in degrees, 8 decimals, of the ENU point (x, y) m."""
        lat, lon, _ = self.origin.enu_to_geodetic(x, y, 0.0)
        return round(lat, 8), round(lon, 8)

    def add(self, command: int, frame: int, params: Sequence[float | None]) -> None:
        """Append one item with the next sequence number."""
        self.items.append(plan_item(command, frame, params, len(self.items) + 1))



def plan_document(items: list[dict[str, Any]], origin: GeoOrigin, home_enu: tuple[float, float, float], *,
                  fence_enu: Sequence[tuple[float, float]] | None = None,
                  fence_radius_m: float | None = None) -> dict[str, Any]:
    """The ``.plan`` JSON around mission items: planned home, geofence polygon / circle about home."""
    def ll(x: float, y: float) -> tuple[float, float]:
        lat, lon, _ = origin.enu_to_geodetic(x, y, 0.0)
        return round(lat, 8), round(lon, 8)

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


def write_plan(path: Path | str, plan: dict[str, Any]) -> None:
    """Write a .plan atomically (temporary file, then rename)."""
    write_text_atomic(path, json.dumps(plan, indent=4) + "\n")
