"""QGroundControl ``.plan`` -> :class:`~vinecli.specs.mission.MissionSpec`.

Simple items are mapped in order onto mission phases; survey /
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
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from vinecli.errors import SpecError
from vinecli.geo import GeoOrigin
from vinecli.inputs import note_input, reading_inputs
from vinecli.missions.qgc_format import (
    DEFAULT_NOZZLE_MAX_FLOW_LPS,
    DO_CHANGE_SPEED,
    DO_SET_ACTUATOR,
    DO_SET_SERVO,
    DO_SPRAYER,
    FRAME_GLOBAL,
    FRAME_GLOBAL_RELATIVE_ALT,
    FRAME_MISSION,
    FRAME_TERRAIN,
    NAV_DELAY,
    NAV_LAND,
    NAV_LOITER_TIME,
    NAV_RTL,
    NAV_TAKEOFF,
    NAV_WAYPOINT,
    SUPPORTED,
    SimpleItem,
    read_plan,
    vehicle_nozzle_flow_lps,
)
from vinecli.missions.qgc_geometry import enu_of, fence_from_plan
from vinecli.names import check_name, name_from
from vinecli.outputs import check_output_file
from vinecli.specs import format_validation_error
from vinecli.specs.limits import MAX_DURATION_S
from vinecli.specs.mission import (
    GotoPhase,
    HoldPhase,
    LandPhase,
    MissionSpec,
    RtlPhase,
    SprayerPhase,
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
        e, n = enu_of(origin, lat, lon)
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
    geofence = fence_from_plan(plan.geoFence, origin, path) if plan.geoFence else None
    return MissionSpec(
        name=name,
        description=f"imported from {path.name}",
        phases=phases,
        geofence=geofence,
        max_duration_s=min(MAX_DURATION_S, round(max(60.0, 1.5 * est + 60.0), 1)),
    )
