"""Mission phases -> MAVLink mission items (MISSION_ITEM_INT), for any firmware that flies MAVLink missions.

:func:`phases_to_items` makes the item list a ground station uploads: take-off, waypoints, speed changes,
loiter, land, RTL, and the sprayer switched with the command the caller chose
(:class:`~vinecli.phase_items.sprayer_command.SprayerCommand`: DO_SET_ACTUATOR for PX4, DO_SPRAYER or
DO_SET_SERVO for ArduPilot). A spray phase becomes THE spray plan (with the vehicle in the context
:func:`vinecli.rows.spray_rate.phase_plan`, the plan the built-in autopilot flies: passes from the
sprayer's effective swath run on past the row ends; without it :func:`vinecli.rows.plan.plan_rows`, a pass
per row; nearest pass first, boustrophedon, headland turns for the vehicle's acceleration, clipped to the
geofence with a 1 m margin) flown as terrain-following waypoints with the sprayer on over the passes only
(:func:`~vinecli.phase_items.spray_legs.leg_actions`). The geofence polygon becomes fence items
(mission_type 1). Firmware parameters (PX4's MIS_TAKEOFF_ALT, GF_*, ...) are the caller's
(:mod:`vinecli.mavlink.px4params` for PX4).

Geometry: x/y are degE7 of WGS84 lat/lon of the world point through the world's georeference
(:func:`~vinecli.mavlink.mission_items.enu_to_degE7`), or float degrees through it exactly for a plan file
(``PlanContext.degrees``: a QGroundControl ``.plan``, :mod:`vinecli.missions.qgc_export`); altitudes in
MAV_FRAME_GLOBAL_RELATIVE_ALT (3) are metres above home; spray heights are above the surface under each waypoint,
expressed above home. Yaw goes out as a heading from true north (turned by the world's grid convergence).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from vinecli.errors import SpecError
from vinecli.frames import yaw_enu_to_heading_ned
from vinecli.geo import GeoOrigin
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.mission_items import MissionItem, item_xy
from vinecli.phase_items.spray_legs import MIN_LEG_M, leg_actions
from vinecli.phase_items.sprayer_command import SprayerCommand
from vinecli.rows.plan import PATH_ACCEL_MPS2, Leg, plan_rows
from vinecli.specs.mission import (
    GeofenceSpec,
    GotoPhase,
    HoldPhase,
    LandPhase,
    MissionSpec,
    OpenLoopPhase,
    RtlPhase,
    SprayerPhase,
    SprayPhase,
    TakeoffPhase,
    WaypointsPhase,
)

__all__ = ["ItemPlan", "PlanContext", "fence_items", "phases_to_items", "sortie_to_items"]

NAN = math.nan


@dataclass
class PlanContext:
    """What the conversion needs from the world and the vehicle."""

    origin: GeoOrigin
    home_enu: tuple[float, float, float]
    vine_rows_enu: Sequence[Sequence[tuple[float, float]]] = ()
    #: ENU z of the surface the spray heights follow (the world's terrain), None: flat at home
    terrain_height: Callable[[float, float], float] | None = None
    nozzle_max_flow_lps: float | None = None  # None: vehicle without a tank
    accel_mps2: float = PATH_ACCEL_MPS2  # the spray plan's headland turns (rows.plan.plan_accel(vehicle))
    firmware: str = "a firmware mission"  # named in the errors ("... not possible with PX4")
    #: the vehicle (VehicleSpec): spray phases fly its plan (rows.spray_rate.phase_plan); None: a pass per row
    vehicle: object = None
    terrain_bounds: tuple[float, float, float, float] | None = None
    air_density: float = 1.225
    #: item x/y as float degrees (a plan file) instead of MAVLink's degE7 ints
    degrees: bool = False
    #: the world's no-spray zones (rings, ENU m): the spray plan closes the sections at them
    no_spray_enu: Sequence[Sequence[tuple[float, float]]] = ()
    #: spray phases dosed per segment: phase index -> SegmentRates (docs/dose.md), and how the firmware follows
    #: them: "actuator" (a flow per piece, switched at its first waypoint led by the pump's lag: PX4's
    #: DO_SET_ACTUATOR) or "switch" (the sprayer on and off at gaps only, the rate set otherwise: ArduPilot)
    segment_rates: dict[int, Any] = field(default_factory=dict)
    rate_items: str = "actuator"

    def home_ground_z(self) -> float:
        hx, hy, hz = self.home_enu
        return float(self.terrain_height(hx, hy)) if callable(self.terrain_height) else hz


@dataclass
class ItemPlan:
    """A mission as items: what is uploaded (mission and fence), which phase each item comes from, and
    the firmware parameters the caller adds (empty here)."""

    items: list[MissionItem]
    fence: list[MissionItem] = field(default_factory=list)
    params: dict[str, float | int] = field(default_factory=dict)  # name -> value (int = INT32)
    phase_of_item: list[int] = field(default_factory=list)
    #: the plan and the rate path (rows.rate_path.RatePath) of every spray phase dosed per segment, by phase index
    rate_paths: dict[int, tuple[Any, Any]] = field(default_factory=dict)


def _flow_fraction(flow_lps: float, ctx: PlanContext, where: str) -> float:
    if flow_lps <= 0.0:
        return 0.0
    if not ctx.nozzle_max_flow_lps:
        raise SpecError(f"{where}: the vehicle has no tank, it cannot spray")
    return min(1.0, flow_lps / ctx.nozzle_max_flow_lps)


def _spray_rows(phase: SprayPhase, ctx: PlanContext, where: str) -> list[list[tuple[float, float]]]:
    world = [list(map(tuple, r)) for r in ctx.vine_rows_enu]
    if phase.rows == "world":
        rows = world
    elif phase.rows and isinstance(phase.rows[0], int):
        try:
            rows = [world[i] for i in phase.rows]  # type: ignore[index]
        except IndexError:
            raise SpecError(f"{where}: row index out of range (the world has {len(world)} rows)") from None
    else:
        rows = [list(r) for r in phase.rows]  # type: ignore[union-attr, arg-type]
    rows = [r for r in rows if len(r) >= 2]
    if not rows:
        raise SpecError(f"{where}: no vine rows to spray")
    return rows  # type: ignore[return-value]


class _Items:
    """The item list under construction and where the vehicle is after it (ENU x, y; altitude above home)."""

    def __init__(self, ctx: PlanContext, sprayer: SprayerCommand) -> None:
        self.ctx, self.sprayer = ctx, sprayer
        self.items: list[MissionItem] = []
        self.pos = (ctx.home_enu[0], ctx.home_enu[1])
        self.alt = 0.0
        self.phase = -1
        self.rate_paths: dict[int, tuple[Any, Any]] = {}

    def wp(self, x: float, y: float, z_rel: float, accept: float = 0.5, yaw_ned_deg: float = NAN,
           cmd: int = M.CMD_NAV_WAYPOINT, p1: float = 0.0) -> None:
        lat, lon = item_xy(self.ctx.origin, x, y, degrees=self.ctx.degrees)
        self.items.append(MissionItem(cmd, M.MAV_FRAME_GLOBAL_RELATIVE_ALT, p1, accept, 0.0, yaw_ned_deg, lat, lon,
                                      z_rel, phase_index=self.phase))
        self.pos, self.alt = (x, y), z_rel

    def here(self, cmd: int, p1: float = 0.0, z_rel: float | None = None) -> None:
        """A position item at the current position (param2 0: the firmware's acceptance)."""
        self.wp(self.pos[0], self.pos[1], self.alt if z_rel is None else z_rel, accept=0.0, cmd=cmd, p1=p1)

    def speed(self, v: float) -> None:
        self.items.append(MissionItem(M.CMD_DO_CHANGE_SPEED, M.MAV_FRAME_MISSION, 1.0, v, -1.0, 0.0,
                                      phase_index=self.phase))

    def spray(self, flow_lps: float, where: str) -> None:
        self.items.append(self.sprayer.item(_flow_fraction(flow_lps, self.ctx, where), self.phase))


def _spray_phase(ph: SprayPhase, out: _Items, fence: Sequence[tuple[float, float]] | None, where: str) -> None:
    ctx = out.ctx
    if ph.until == "empty":
        raise SpecError(f"{where}: 'until: empty' is not possible with {ctx.firmware} (a mission is fixed at upload; "
                        "use rows_done)")
    if ph.refill is not None:
        raise SpecError(f"{where}: refill sorties need the built-in autopilot (the simulated ground crew "
                        f"serves its landings); with {ctx.firmware} export one plan per sortie (vinecli plan)")
    if ph.flow_lps is None:  # rate_lpha: the runner resolves it against the vehicle (rows/spray_rate.py)
        raise SpecError(f"{where}: a spray phase given as rate_lpha needs its flow from the vehicle's nozzles; "
                        "resolve it first (vinecli.rows.spray_rate.resolve_spray_rates) or give flow_lps")
    _flow_fraction(ph.flow_lps, ctx, where)  # a vehicle without a tank cannot spray
    rows = _spray_rows(ph, ctx, where)
    if ctx.vehicle is not None:
        from vinecli.rows.spray_rate import phase_plan

        plan = phase_plan(ph, ctx.vehicle, rows, out.pos, fence_enu=fence,  # type: ignore[arg-type]
                          terrain_bounds=ctx.terrain_bounds, air_density=ctx.air_density, no_spray=ctx.no_spray_enu)
    else:
        plan = plan_rows(rows, out.pos, speed_mps=ph.speed_mps, accel_mps2=ctx.accel_mps2, fence_enu=fence,
                         no_spray=ctx.no_spray_enu)
    if not plan.legs:
        raise SpecError(f"{where}: no rows left inside the geofence")
    rates = ctx.segment_rates.get(out.phase)
    if rates is not None and ctx.vehicle is not None:
        legs, flows = _rate_legs(ph, plan, rates, rows, out)
        _fly_legs(out, legs, ph.speed_mps, ph.height_agl_m, ph.flow_lps, where, flows)
        return
    _fly_legs(out, plan.legs, ph.speed_mps, ph.height_agl_m, ph.flow_lps, where)


def _rate_legs(ph: SprayPhase, plan: Any, rates: Any, rows: Any, out: _Items) -> tuple[list[Leg], list[float]]:
    """The plan's legs at segment rates (:func:`vinecli.rows.rate_path.rate_path`) as the firmware follows them
    (``PlanContext.rate_items``) and each leg's flow at the phase's speed, L/s."""
    from vinecli.rows.rate_path import led_changes, rate_legs, rate_path

    v = out.ctx.vehicle
    sp = v.sprayer  # type: ignore[attr-defined]
    rp = rate_path(plan, rates, rows, speed_mps=ph.speed_mps, speed_min_mps=sp.control.speed_min_mps,
                   flow_range_lps=sp.flow_range_lps(out.ctx.nozzle_max_flow_lps or 0.0))
    out.rate_paths[out.phase] = (plan, rp)
    if out.ctx.rate_items == "actuator":
        pts, flows = led_changes(rp.points, rp.flows, ph.speed_mps * sp.pump.tau_up_s, ph.speed_mps * sp.pump.tau_down_s)
        legs = rate_legs(pts, flows, min_leg_m=MIN_LEG_M)  # a firmware slows down at waypoints closer than that
    else:
        legs = rate_legs(rp.points, rp.flows, merge_sprayed=True)
    return [leg for leg, _ in legs], [f * ph.speed_mps for _, f in legs]


def _run_in_m(speed_mps: float, ctx: PlanContext) -> float:
    """The longest run-in of a plan at ``speed_mps`` (its v² / 2a, rows.plan), with 0.1 m to spare, m."""
    return speed_mps * speed_mps / (2.0 * ctx.accel_mps2) + 0.1


def _fly_legs(out: _Items, legs: Sequence[Leg], speed_mps: float, height_m: float, flow_lps: float,
              where: str, leg_flows: Sequence[float] | None = None) -> None:
    """Planned legs as terrain-following waypoints, the sprayer on over the spray legs only (leg_actions)."""
    ctx = out.ctx
    out.speed(speed_mps)
    out.spray(0.0, where)  # off during the transit, whatever an earlier phase left on
    surface = ctx.terrain_height if callable(ctx.terrain_height) else None
    for kind, a, b, c in leg_actions(legs, height_m=height_m, flow_lps=flow_lps, surface=surface,
                                     home_z=ctx.home_ground_z(), leg_flows=leg_flows,
                                     open_at_run_in=_run_in_m(speed_mps, ctx) if out.sprayer.command == M.CMD_DO_SPRAYER
                                     else 0.0):
        if kind == "wp":
            out.wp(a, b, c)
        elif kind == "face":  # the waypoint just added: its yaw (a heading from true north, deg)
            if out.items[-1].command == M.CMD_NAV_WAYPOINT:
                out.items[-1].param4 = math.degrees(yaw_enu_to_heading_ned(a + ctx.origin.convergence_rad))
        else:
            out.spray(a, where)


def phases_to_items(mission: MissionSpec, ctx: PlanContext, *, sprayer: SprayerCommand) -> ItemPlan:
    """``mission`` as mission items (module doc); SpecError for phases a firmware mission cannot fly."""
    out = _Items(ctx, sprayer)
    gf = mission.geofence
    fence = gf.polygon_enu if gf is not None and gf.polygon_enu else None
    for pi, ph in enumerate(mission.phases):
        out.phase = pi
        where = f"mission {mission.name!r} phase {pi + 1} ({ph.type})"
        if isinstance(ph, OpenLoopPhase):
            raise SpecError(f"{where}: open-loop phases are not possible with {ctx.firmware} (use --autopilot builtin)")
        if isinstance(ph, TakeoffPhase):
            out.here(M.CMD_NAV_TAKEOFF, z_rel=ph.altitude_agl_m)
        elif isinstance(ph, HoldPhase):
            out.here(M.CMD_NAV_LOITER_TIME, p1=ph.duration_s)
        elif isinstance(ph, GotoPhase):
            if ph.speed_mps is not None:
                out.speed(ph.speed_mps)
            yaw = NAN if ph.yaw_deg is None else math.degrees(  # a heading from true north
                yaw_enu_to_heading_ned(math.radians(ph.yaw_deg) + ctx.origin.convergence_rad))
            alt = ph.altitude_agl_m if ph.altitude_agl_m is not None else out.alt
            out.wp(ph.position_enu[0], ph.position_enu[1], alt, accept=ph.acceptance_radius_m, yaw_ned_deg=yaw)
        elif isinstance(ph, WaypointsPhase):
            out.speed(ph.speed_mps)
            if ph.flow_lps is not None:
                out.spray(ph.flow_lps, where)
            for x, y, a in ph.waypoints:
                out.wp(x, y, a, accept=ph.acceptance_radius_m)
        elif isinstance(ph, SprayPhase):
            _spray_phase(ph, out, fence, where)
        elif isinstance(ph, SprayerPhase):
            out.spray(ph.flow_lps, where)
        elif isinstance(ph, LandPhase):
            out.here(M.CMD_NAV_LAND, z_rel=0.0)
        elif isinstance(ph, RtlPhase):
            out.items.append(MissionItem(M.CMD_NAV_RETURN_TO_LAUNCH, M.MAV_FRAME_MISSION, phase_index=pi))
            out.pos, out.alt = (ctx.home_enu[0], ctx.home_enu[1]), 0.0
        else:  # pragma: no cover - exhaustive over the Phase union
            raise SpecError(f"{where}: unsupported phase type")
    items = out.items
    return ItemPlan(items=items, fence=fence_items(gf, ctx.origin, degrees=ctx.degrees),
                    phase_of_item=[it.phase_index for it in items], rate_paths=out.rate_paths)


def sortie_to_items(legs: Sequence[Leg], ctx: PlanContext, *, sprayer: SprayerCommand, takeoff_m: float,
                    height_m: float, speed_mps: float, flow_lps: float) -> ItemPlan:
    """One sortie of an already planned and split spray job (:func:`vinecli.rows.plan.split_sorties`) as
    items: take-off at home to ``takeoff_m``, the transit from home to the first leg and the legs as a spray
    phase flies them (``height_m`` above the surface, ``flow_lps`` over the rows, ``speed_mps``), return to
    launch."""
    out = _Items(ctx, sprayer)
    where = "sortie"
    _flow_fraction(flow_lps, ctx, where)
    out.here(M.CMD_NAV_TAKEOFF, z_rel=takeoff_m)
    transit = Leg([out.pos, legs[0].points[0]], False, None, "transit")
    _fly_legs(out, [transit, *legs], speed_mps, height_m, flow_lps, where)
    out.items.append(MissionItem(M.CMD_NAV_RETURN_TO_LAUNCH, M.MAV_FRAME_MISSION))
    return ItemPlan(items=out.items, phase_of_item=[it.phase_index for it in out.items])


def fence_items(fence: GeofenceSpec | None, origin: GeoOrigin, *, degrees: bool = False) -> list[MissionItem]:
    """The geofence's inclusion polygon as fence items (mission_type 1, NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    param1 = the vertex count); the distance and altitude limits are firmware parameters (the caller's)."""
    if fence is None or not fence.polygon_enu:
        return []
    n = len(fence.polygon_enu)
    items = []
    for x, y in fence.polygon_enu:
        lat, lon = item_xy(origin, x, y, degrees=degrees)
        items.append(MissionItem(M.CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, M.MAV_FRAME_GLOBAL, float(n), 0.0, 0.0, 0.0,
                                 lat, lon, 0.0, mission_type=M.MAV_MISSION_TYPE_FENCE))
    return items
