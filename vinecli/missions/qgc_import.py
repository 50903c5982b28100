"""QGroundControl ``.plan`` -> :class:`~vinecli.specs.mission.MissionSpec`, through THE phase <-> mission-item
converter (:func:`vinecli.phase_items.items_to_phases`, its ``compact`` form: consecutive waypoints as one
``waypoints`` phase).

The plan's simple items are read in order as mission items; survey / corridor items are flattened from
``TransectStyleComplexItem.Items`` (QGC stores the generated waypoints there); ``geoFence`` becomes the mission's
geofence. Latitude/longitude (float degrees) go to the world's frame through its georeference
(:func:`~vinecli.mavlink.mission_items.item_enu`: the tangent plane at the origin, or a CRS world's
:class:`~vinecli.geo.GeoFrame`; headings turned by its grid convergence); altitudes become heights above home
(frame 3 = relative already; frame 0 = AMSL minus the home altitude; frame 10 = terrain altitude, taken as above
home). What the converter would skip or guess is refused here, naming the file and the item
(``mission.items[4]`` or ``mission.items[2].TransectStyleComplexItem.Items[7]``): unsupported commands or
frames, waypoints without a position or an altitude, a take-off not above home, DO_SET_SERVO without a PWM, a
delay without seconds. Commands: :mod:`vinecli.phase_items.to_phases`; the sprayer: DO_SET_ACTUATOR p1 = fraction
of the nozzle's maximum flow, DO_SET_SERVO (output 9) PWM 1000..2000 µs, DO_SPRAYER on = ``spray_flow_lps``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from pydantic import ValidationError

from vinecli.errors import SpecError
from vinecli.geo import GeoOrigin
from vinecli.inputs import note_input, reading_inputs
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.mission_items import SUPPORTED_MISSION_COMMANDS, MissionItem, item_enu
from vinecli.missions.qgc_format import (
    DEFAULT_NOZZLE_MAX_FLOW_LPS,
    GeoFence,
    Plan,
    SimpleItem,
    read_plan,
    vehicle_nozzle_flow_lps,
)
from vinecli.names import check_name, name_from
from vinecli.outputs import check_output_file
from vinecli.phase_items import items_to_phases
from vinecli.specs import format_validation_error
from vinecli.specs.limits import MAX_DURATION_S
from vinecli.specs.mission import (
    GeofenceSpec,
    GotoPhase,
    HoldPhase,
    LandPhase,
    MissionSpec,
    RtlPhase,
    TakeoffPhase,
    WaypointsPhase,
)

__all__ = ["import_plan", "import_plan_for_world"]


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
        write_mission(out, mission, overwrite=overwrite)
    return mission


_POSITIONED = {M.CMD_NAV_WAYPOINT, M.CMD_NAV_LOITER_TIME, M.CMD_NAV_LAND, M.CMD_NAV_TAKEOFF}
_FRAMES = (0, 3, 10)  # global: AMSL, above home, above terrain


def _import_plan(path: Path, origin: GeoOrigin, nozzle_max_flow_lps: float, spray_flow_lps: float | None,
                 name: str, home_alt_m: float | None) -> MissionSpec:
    plan = read_plan(path)
    h_alt = float(plan.mission.plannedHomePosition[2]) if home_alt_m is None else home_alt_m
    items = [_mission_item(where, it, h_alt, path) for where, it in _flat_items(plan, path)]
    spray_on = spray_flow_lps if spray_flow_lps is not None else 0.5 * nozzle_max_flow_lps
    speed = float(plan.mission.hoverSpeed) if plan.mission.hoverSpeed > 0 else 2.0
    phases, _ = items_to_phases(items, origin, h_alt, nozzle_max_flow_lps, degrees=True,
                                sprayer_on=spray_on / nozzle_max_flow_lps, compact=True, speed_mps=speed)
    if not phases:
        raise SpecError("mission.items: nothing to fly", path=path)
    geofence = _fence_from_plan(plan.geoFence, origin, path) if plan.geoFence else None
    est = _estimated_s(phases, speed)
    return MissionSpec(name=name, description=f"imported from {path.name}", phases=phases, geofence=geofence,
                       max_duration_s=min(MAX_DURATION_S, round(max(60.0, 1.5 * est + 60.0), 1)))


def _flat_items(plan: Plan, path: Path) -> list[tuple[str, SimpleItem]]:
    """The plan's simple items in order, each with where it is in the file; complex items flattened."""
    flat: list[tuple[str, SimpleItem]] = []
    for i, it in enumerate(plan.mission.items):
        if isinstance(it, SimpleItem):
            flat.append((f"mission.items[{i}]", it))
            continue
        ts = it.TransectStyleComplexItem
        if ts is None or not ts.Items:
            raise SpecError(f"mission.items[{i}]: complex item {it.complexItemType!r} has no "
                            "TransectStyleComplexItem.Items to flatten", path=path)
        flat += [(f"mission.items[{i}].TransectStyleComplexItem.Items[{j}]", s) for j, s in enumerate(ts.Items)]
    return flat


def _mission_item(where: str, it: SimpleItem, home_alt: float, path: Path) -> MissionItem:
    """One plan item as a mission item (x, y float degrees), or a SpecError naming it (module doc)."""
    c = it.command
    if c not in SUPPORTED_MISSION_COMMANDS:
        raise SpecError(f"{where}: unsupported command {c} (supported: {sorted(SUPPORTED_MISSION_COMMANDS)})",
                        path=path)
    lat, lon, alt = it.p(5), it.p(6), it.p(7)
    positioned = c in _POSITIONED and math.isfinite(lat) and math.isfinite(lon) and not (lat == 0.0 and lon == 0.0)
    if positioned and it.frame not in _FRAMES:
        raise SpecError(f"{where}: unsupported frame {it.frame} (use 0, 3 or 10)", path=path)
    if c == M.CMD_NAV_WAYPOINT and not positioned:
        raise SpecError(f"{where}: waypoint without a position", path=path)
    if positioned and c != M.CMD_NAV_LAND and math.isnan(alt):
        raise SpecError(f"{where}: altitude (param 7) is missing", path=path)
    if c == M.CMD_NAV_TAKEOFF and not (alt - (home_alt if it.frame == 0 else 0.0)) > 0:
        raise SpecError(f"{where}: takeoff altitude must be > 0 m above home", path=path)
    if c == M.CMD_DO_SET_SERVO and math.isnan(it.p(2)):
        raise SpecError(f"{where}: DO_SET_SERVO without a PWM value (param 2)", path=path)
    if c in (M.CMD_NAV_DELAY, M.CMD_CONDITION_DELAY) and not it.p(1) > 0:
        raise SpecError(f"{where}: a delay needs seconds (param 1)", path=path)
    return MissionItem(c, it.frame, it.p(1), it.p(2), it.p(3), it.p(4), lat if positioned else 0,
                       lon if positioned else 0, alt)


def _estimated_s(phases: Sequence[object], default_speed: float) -> float:
    """Rough flight time, s: the path from home at each phase's speed, the holds, 30 s per take-off/landing/RTL."""
    t, at = 0.0, (0.0, 0.0)
    for p in phases:
        if isinstance(p, (GotoPhase, WaypointsPhase)):
            pts = [p.position_enu] if isinstance(p, GotoPhase) else [w[:2] for w in p.waypoints]
            v = p.speed_mps or default_speed
            for q in pts:
                t += math.dist(at, q) / max(v, 0.5)
                at = (q[0], q[1])
        elif isinstance(p, HoldPhase):
            t += p.duration_s
        elif isinstance(p, (TakeoffPhase, LandPhase, RtlPhase)):
            t += 30.0
    return t


def _fence_from_plan(fence: GeoFence, origin: GeoOrigin, path: Path) -> GeofenceSpec | None:
    """The plan's geoFence as a GeofenceSpec in world ENU (one inclusion polygon, or a circle: about home the
    horizontal distance limit, elsewhere a 32-gon); None when it has neither; SpecError for what has no equivalent."""
    polygon: list[tuple[float, float]] | None = None
    radius: float | None = None
    for i, poly in enumerate(fence.polygons):
        if not poly.inclusion:
            raise SpecError(f"geoFence.polygons[{i}]: exclusion polygons are not supported", path=path)
        if polygon is not None:
            raise SpecError(f"geoFence.polygons[{i}]: only one inclusion polygon is supported", path=path)
        pts = [item_enu(origin, v[0], v[1], degrees=True) for v in poly.polygon]
        polygon = [(round(e, 4), round(n, 4)) for e, n in pts]
    for i, c in enumerate(fence.circles):
        if not c.inclusion:
            raise SpecError(f"geoFence.circles[{i}]: exclusion circles are not supported", path=path)
        e, n = item_enu(origin, c.circle.center[0], c.circle.center[1], degrees=True)
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
