"""Mission phases (vinecli MissionSpec) <-> MAVLink mission items (MISSION_ITEM_INT).

Both directions are used: :func:`phases_to_items` builds what vinecli uploads to PX4
(takeoff, waypoints, speed changes, DO_SET_ACTUATOR for the sprayer, loiter, land, RTL;
spray phases expanded into row waypoints with the sprayer switched on along each row and off
in the turns); :func:`items_to_phases` turns an uploaded mission back into phases a built-in
autopilot can fly (the vehicle endpoint and the fake PX4 peer).

Geometry: x/y are degE7 of WGS84 lat/lon from the world's origin by the local-tangent
approximation (:meth:`GeoOrigin.enu_to_geodetic_fast`, < 1 mm within 1 km); altitudes in
MAV_FRAME_GLOBAL_RELATIVE_ALT (3) are metres above home. Spray heights are above the terrain
under each waypoint (terrain sampled from the world), converted to above-home.
Sprayer: DO_SET_ACTUATOR param1 (actuator set 1) = flow / nozzle_max_flow in [0, 1].
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from vinecli.errors import SpecError
from vinecli.frames import heading_ned_to_yaw_enu, yaw_enu_to_heading_ned
from vinecli.geo import GeoOrigin
from vinecli.mavlink import px4modes as M
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

NAN = float("nan")


@dataclass
class MissionItem:
    """One MISSION_ITEM_INT (without seq/target): x, y degE7 (or int params), z float."""

    command: int
    frame: int = M.MAV_FRAME_MISSION
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0
    autocontinue: int = 1
    mission_type: int = M.MAV_MISSION_TYPE_MISSION
    phase_index: int = -1  # mission phase this item comes from (vinecli side), -1 unknown

    @classmethod
    def from_msg(cls, msg: object) -> MissionItem:
        """From a pymavlink MISSION_ITEM_INT (or legacy MISSION_ITEM: x/y floats in degrees)."""
        x, y = msg.x, msg.y  # type: ignore[attr-defined]
        if msg.get_type() == "MISSION_ITEM" and msg.frame in (0, 3, 10):  # type: ignore[attr-defined]
            x, y = round(x * 1e7), round(y * 1e7)
        return cls(
            command=msg.command, frame=msg.frame,  # type: ignore[attr-defined]
            param1=msg.param1, param2=msg.param2, param3=msg.param3, param4=msg.param4,  # type: ignore[attr-defined]
            x=int(x), y=int(y), z=float(msg.z), autocontinue=msg.autocontinue,  # type: ignore[attr-defined]
            mission_type=getattr(msg, "mission_type", 0),
        )

    def encode(self, mav: object, seq: int, target_system: int, target_component: int, current: int = 0) -> object:
        """A pymavlink MISSION_ITEM_INT message for this item."""
        return mav.mission_item_int_encode(  # type: ignore[attr-defined]
            target_system, target_component, seq, self.frame, self.command, current, self.autocontinue,
            self.param1, self.param2, self.param3, self.param4, self.x, self.y, self.z, self.mission_type,
        )


@dataclass
class PlanContext:
    """What the conversion needs from the world."""

    origin: GeoOrigin
    home_enu: tuple[float, float, float]
    vine_rows_enu: Sequence[Sequence[tuple[float, float]]] = ()
    terrain_height: Callable[[float, float], float] | None = None
    nozzle_max_flow_lps: float | None = None  # None: vehicle without a tank

    def home_ground_z(self) -> float:
        hx, hy, hz = self.home_enu
        return float(self.terrain_height(hx, hy)) if callable(self.terrain_height) else hz

    def ground_z(self, x: float, y: float) -> float:
        return float(self.terrain_height(x, y)) if callable(self.terrain_height) else self.home_ground_z()


@dataclass
class Px4Plan:
    """Everything uploaded to PX4 for one mission."""

    items: list[MissionItem]
    fence: list[MissionItem] = field(default_factory=list)
    params: dict[str, float | int] = field(default_factory=dict)  # name -> value (int = INT32)
    phase_of_item: list[int] = field(default_factory=list)


# ---------------------------------------------------------------- geometry helpers
def enu_to_degE7(origin: GeoOrigin, x: float, y: float) -> tuple[int, int]:
    """ENU (m) -> (lat degE7, lon degE7)."""
    lat, lon, _ = origin.enu_to_geodetic_fast(x, y, 0.0)
    return round(lat * 1e7), round(lon * 1e7)


def degE7_to_enu(origin: GeoOrigin, lat_e7: int, lon_e7: int) -> tuple[float, float]:
    """(lat degE7, lon degE7) -> ENU (x, y) m, inverse of :func:`enu_to_degE7`."""
    m_lat, m_lon = origin.metres_per_degree
    return ((lon_e7 * 1e-7 - origin.lon) * m_lon, (lat_e7 * 1e-7 - origin.lat) * m_lat)


def _flow_to_u(flow_lps: float, ctx: PlanContext, where: str) -> float:
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


# ---------------------------------------------------------------- phases -> items (upload to PX4)
def phases_to_items(mission: MissionSpec, ctx: PlanContext) -> Px4Plan:
    """Convert a mission for PX4 (SpecError for phases PX4 cannot fly)."""
    items: list[MissionItem] = []
    params: dict[str, float | int] = {}
    home_ground = ctx.home_ground_z()
    pos = (ctx.home_enu[0], ctx.home_enu[1])
    alt_rel = 0.0  # current planned altitude above home, m

    def wp(x: float, y: float, z_rel: float, pi: int, accept: float = 0.5, yaw_ned_deg: float = NAN,
           cmd: int = M.CMD_NAV_WAYPOINT, p1: float = 0.0) -> None:
        lat, lon = enu_to_degE7(ctx.origin, x, y)
        items.append(MissionItem(cmd, M.MAV_FRAME_GLOBAL_RELATIVE_ALT, p1, accept, 0.0, yaw_ned_deg, lat, lon, z_rel, phase_index=pi))

    def speed(v: float, pi: int) -> None:
        items.append(MissionItem(M.CMD_DO_CHANGE_SPEED, M.MAV_FRAME_MISSION, 1.0, v, -1.0, 0.0, phase_index=pi))

    def sprayer(u: float, pi: int) -> None:
        items.append(MissionItem(M.CMD_DO_SET_ACTUATOR, M.MAV_FRAME_MISSION, u, NAN, NAN, NAN, 0, 0, 0.0, phase_index=pi))

    for pi, ph in enumerate(mission.phases):
        where = f"mission {mission.name!r} phase {pi + 1} ({ph.type})"
        if isinstance(ph, OpenLoopPhase):
            raise SpecError(f"{where}: open-loop phases are not possible with PX4 (use --autopilot builtin)")
        if isinstance(ph, TakeoffPhase):
            alt_rel = ph.altitude_agl_m
            params["MIS_TAKEOFF_ALT"] = float(ph.altitude_agl_m)
            # PX4 accepts an item's altitude within NAV_MC_ALT_RAD (default 0.8 m): the phase's tolerance
            params["NAV_MC_ALT_RAD"] = min(float(params.get("NAV_MC_ALT_RAD", math.inf)), float(ph.tolerance_m))
            if ph.climb_speed_mps is not None:  # the takeoff ramp's target and the auto climb after it,
                params["MPC_TKO_SPEED"] = params["MPC_Z_V_AUTO_UP"] = float(ph.climb_speed_mps)
                params["MPC_TKO_RAMP_T"] = 1.0  # reached in 1 s (PX4 default 3 s: no steady climb in 8 m)
            wp(pos[0], pos[1], alt_rel, pi, cmd=M.CMD_NAV_TAKEOFF)
            items[-1].param2 = 0.0
        elif isinstance(ph, HoldPhase):
            wp(pos[0], pos[1], alt_rel, pi, cmd=M.CMD_NAV_LOITER_TIME, p1=ph.duration_s)
            items[-1].param2 = 0.0
        elif isinstance(ph, GotoPhase):
            if ph.speed_mps is not None:
                speed(ph.speed_mps, pi)
            if ph.altitude_agl_m is not None:
                alt_rel = ph.altitude_agl_m
            yaw = NAN if ph.yaw_deg is None else math.degrees(yaw_enu_to_heading_ned(math.radians(ph.yaw_deg)))
            pos = ph.position_enu
            wp(pos[0], pos[1], alt_rel, pi, accept=ph.acceptance_radius_m, yaw_ned_deg=yaw)
        elif isinstance(ph, WaypointsPhase):
            speed(ph.speed_mps, pi)
            if ph.flow_lps is not None:
                sprayer(_flow_to_u(ph.flow_lps, ctx, where), pi)
            for x, y, a in ph.waypoints:
                pos, alt_rel = (x, y), a
                wp(x, y, a, pi, accept=ph.acceptance_radius_m)
        elif isinstance(ph, SprayPhase):
            if ph.until == "empty":
                raise SpecError(f"{where}: 'until: empty' is not possible with PX4 (a PX4 mission is fixed at upload; use rows_done)")
            if ph.refill is not None:
                raise SpecError(f"{where}: refill sorties need the built-in autopilot (the simulated ground crew "
                                "serves its landings); with PX4 export one plan per sortie (vinecli plan)")
            if ph.flow_lps is None:  # rate_lpha: the runner resolves it against the vehicle (missions/spray_rate.py)
                raise SpecError(f"{where}: a spray phase given as rate_lpha needs its flow from the vehicle's nozzles; "
                                "resolve it first (vinecli.rows.spray_rate.resolve_spray_rates) or give flow_lps")
            u = _flow_to_u(ph.flow_lps, ctx, where)
            rows = _spray_rows(ph, ctx, where)
            speed(ph.speed_mps, pi)
            sprayer(0.0, pi)
            for k, row in enumerate(rows):
                pts = row if k % 2 == 0 else row[::-1]
                for j, (x, y) in enumerate(pts):
                    z = ctx.ground_z(x, y) + ph.height_agl_m - home_ground
                    wp(x, y, z, pi, accept=0.5)
                    pos, alt_rel = (x, y), z
                    if j == 0:
                        sprayer(u, pi)
                sprayer(0.0, pi)
        elif isinstance(ph, SprayerPhase):
            sprayer(_flow_to_u(ph.flow_lps, ctx, where), pi)
        elif isinstance(ph, LandPhase):
            params["MPC_LAND_SPEED"] = float(ph.descent_speed_mps)
            wp(pos[0], pos[1], 0.0, pi, cmd=M.CMD_NAV_LAND)
            items[-1].param2 = 0.0
            alt_rel = 0.0
        elif isinstance(ph, RtlPhase):
            params["RTL_RETURN_ALT"] = float(ph.return_altitude_agl_m)
            items.append(MissionItem(M.CMD_NAV_RETURN_TO_LAUNCH, M.MAV_FRAME_MISSION, phase_index=pi))
            pos, alt_rel = (ctx.home_enu[0], ctx.home_enu[1]), 0.0
        else:  # pragma: no cover - exhaustive over the Phase union
            raise SpecError(f"{where}: unsupported phase type")
    fence, fparams = fence_items(mission.geofence, ctx)
    params.update(fparams)
    return Px4Plan(items=items, fence=fence, params=params, phase_of_item=[it.phase_index for it in items])


def fence_items(fence: GeofenceSpec | None, ctx: PlanContext) -> tuple[list[MissionItem], dict[str, float | int]]:
    """Geofence -> mission_type 1 items (polygon inclusion) and GF_* parameters."""
    if fence is None:
        return [], {}
    params: dict[str, float | int] = {"GF_ACTION": M.GF_ACTION[fence.action]}
    if fence.max_horizontal_distance_m is not None:
        params["GF_MAX_HOR_DIST"] = float(fence.max_horizontal_distance_m)
    if fence.max_altitude_agl_m is not None:
        params["GF_MAX_VER_DIST"] = float(fence.max_altitude_agl_m)
    items = []
    if fence.polygon_enu:
        n = len(fence.polygon_enu)
        for x, y in fence.polygon_enu:
            lat, lon = enu_to_degE7(ctx.origin, x, y)
            items.append(MissionItem(M.CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, M.MAV_FRAME_GLOBAL, float(n), 0.0, 0.0, 0.0,
                                     lat, lon, 0.0, mission_type=M.MAV_MISSION_TYPE_FENCE))
    return items, params


# ---------------------------------------------------------------- items -> phases (fly an uploaded mission)
#: commands :func:`items_to_phases` understands (others are answered MAV_MISSION_UNSUPPORTED)
SUPPORTED_MISSION_COMMANDS = frozenset({
    M.CMD_NAV_WAYPOINT, M.CMD_NAV_LOITER_TIME, M.CMD_NAV_RETURN_TO_LAUNCH, M.CMD_NAV_LAND, M.CMD_NAV_TAKEOFF,
    M.CMD_NAV_DELAY, M.CMD_CONDITION_DELAY, M.CMD_DO_CHANGE_SPEED, M.CMD_DO_SET_ACTUATOR, M.CMD_DO_SET_SERVO, M.CMD_DO_SPRAYER,
})
GLOBAL_FRAMES = frozenset({0, 3, 5, 6})


def check_item(it: MissionItem) -> int:
    """MAV_MISSION_RESULT for one uploaded item (0 accepted, 3 unsupported command, 2 bad frame)."""
    if it.command not in SUPPORTED_MISSION_COMMANDS:
        return M.MAV_MISSION_UNSUPPORTED
    nav_pos = it.command in (M.CMD_NAV_WAYPOINT, M.CMD_NAV_LOITER_TIME, M.CMD_NAV_TAKEOFF)
    if nav_pos and it.frame not in GLOBAL_FRAMES:
        return M.MAV_MISSION_UNSUPPORTED_FRAME
    return M.MAV_MISSION_ACCEPTED


def items_to_phases(
    items: Sequence[MissionItem], origin: GeoOrigin, home_alt_amsl: float, nozzle_max_flow_lps: float | None,
    takeoff_alt_default: float = 2.5, sprayer_servo: int = 9,
) -> tuple[list[object], list[int]]:
    """Phases flying ``items`` and, per phase, the index of the item it comes from.

    Altitudes: relative frames (3, 6) are above home; absolute (0, 5) are AMSL minus home.
    ``sprayer_servo``: DO_SET_SERVO output number treated as the pump (ArduPilot style, PWM 1000-2000).
    """
    phases: list[object] = []
    src: list[int] = []
    speed: float | None = None
    nozzle = nozzle_max_flow_lps or 0.0

    def rel(it: MissionItem) -> float:
        return it.z if it.frame in (3, 6) else it.z - home_alt_amsl

    def has_pos(it: MissionItem) -> bool:
        return not (it.x == 0 and it.y == 0)

    for k, it in enumerate(items):
        c = it.command
        if c == M.CMD_NAV_TAKEOFF:
            alt = rel(it) if math.isfinite(it.z) and rel(it) > 0 else takeoff_alt_default
            phases.append(TakeoffPhase(altitude_agl_m=alt))
        elif c in (M.CMD_NAV_WAYPOINT, M.CMD_NAV_LOITER_TIME):
            x, y = degE7_to_enu(origin, it.x, it.y)
            yaw = None
            if c == M.CMD_NAV_WAYPOINT and math.isfinite(it.param4):
                yaw = math.degrees(heading_ned_to_yaw_enu(math.radians(it.param4)))
            accept = it.param2 if c == M.CMD_NAV_WAYPOINT and it.param2 > 0 else 0.5
            z = rel(it) if math.isfinite(it.z) else None
            if has_pos(it):
                phases.append(GotoPhase(position_enu=(x, y), altitude_agl_m=z, speed_mps=speed, acceptance_radius_m=accept, yaw_deg=yaw))
                src.append(k)
            hold = it.param1  # hold / loiter time at the waypoint, s
            if hold > 0:
                phases.append(HoldPhase(duration_s=hold))
                src.append(k)
            continue
        elif c in (M.CMD_NAV_DELAY, M.CMD_CONDITION_DELAY):
            if it.param1 > 0:
                phases.append(HoldPhase(duration_s=it.param1))
            else:
                continue
        elif c == M.CMD_DO_CHANGE_SPEED:
            if it.param2 > 0:
                speed = it.param2
            continue
        elif c in (M.CMD_DO_SET_ACTUATOR, M.CMD_DO_SET_SERVO, M.CMD_DO_SPRAYER):
            if c == M.CMD_DO_SET_ACTUATOR:
                if not math.isfinite(it.param1):
                    continue
                u = it.param1
            elif c == M.CMD_DO_SET_SERVO:
                if int(it.param1) != sprayer_servo:
                    continue
                u = (it.param2 - 1000.0) / 1000.0
            else:
                u = 1.0 if it.param1 >= 0.5 else 0.0
            phases.append(SprayerPhase(flow_lps=max(0.0, min(1.0, u)) * nozzle))
        elif c == M.CMD_NAV_LAND:
            if has_pos(it):
                x, y = degE7_to_enu(origin, it.x, it.y)
                phases.append(GotoPhase(position_enu=(x, y), speed_mps=speed, acceptance_radius_m=0.5))
                src.append(k)
            phases.append(LandPhase())
        elif c == M.CMD_NAV_RETURN_TO_LAUNCH:
            phases.append(RtlPhase())
        else:
            continue
        src.append(k)
    return phases, src
