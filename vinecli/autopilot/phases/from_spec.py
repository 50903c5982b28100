"""The runnable phases of a built-in autopilot mission: :func:`make_phase` turns a mission phase
spec (:mod:`vinecli.specs.mission`) into a :class:`~vinecli.autopilot.phases.phase.Phase`.

The phase classes live in :mod:`vinecli.autopilot.phases.flight` (take-off, hold, goto,
waypoints, sprayer, land, RTL, open loop) and :mod:`vinecli.autopilot.phases.spray` (spray with
its refill sorties). Altitudes ``*_agl_m`` of goto and waypoints are above home (ENU m).
"""

from __future__ import annotations

from vinecli.autopilot.base import AutopilotContext
from vinecli.autopilot.phases.flight import FollowPath, Hold, Land, OpenLoop, Rtl, SetSprayerFlow, Takeoff
from vinecli.autopilot.phases.phase import Phase, PhaseHost
from vinecli.autopilot.phases.spray import Spray, spray_rows
from vinecli.control.path import PathFollower
from vinecli.errors import InputError
from vinecli.specs.mission import (
    GotoPhase,
    HoldPhase,
    LandPhase,
    OpenLoopPhase,
    RtlPhase,
    SprayerPhase,
    SprayPhase,
    TakeoffPhase,
    WaypointsPhase,
)


def make_phase(p: object, ctx: AutopilotContext) -> Phase:
    """The phase that flies mission phase spec ``p`` in the run ``ctx``; InputError for an unsupported
    spec or rows the spray phase cannot use."""
    v = ctx.vehicle
    if isinstance(p, TakeoffPhase):
        return Takeoff(p, v)
    if isinstance(p, HoldPhase):
        return Hold(p.duration_s)
    if isinstance(p, GotoPhase):
        g = p

        def make_goto(ap: PhaseHost) -> PathFollower:
            x, y, z = ap.hold_sp()
            zt = ap.home[2] + g.altitude_agl_m if g.altitude_agl_m is not None else z
            speed = g.speed_mps or min(5.0, v.control.max_vel_xy)
            return PathFollower([(x, y, z), (g.position_enu[0], g.position_enu[1], zt)], speed,
                                acceptance_m=g.acceptance_radius_m, max_up=v.control.max_vel_up,
                                max_down=v.control.max_vel_down)

        return FollowPath("goto", make_goto, p.timeout_s, yaw_deg=p.yaw_deg)
    if isinstance(p, WaypointsPhase):
        w = p

        def make_wp(ap: PhaseHost) -> PathFollower:
            pts = [ap.hold_sp()] + [(x, y, ap.home[2] + a) for x, y, a in w.waypoints]
            fl = [w.flow_lps if w.flow_lps is not None else ap.flow] * (len(pts) - 1)
            return PathFollower(pts, w.speed_mps, acceptance_m=w.acceptance_radius_m, flows=fl,
                                max_up=v.control.max_vel_up, max_down=v.control.max_vel_down)

        return FollowPath("waypoints", make_wp, p.timeout_s, flow=p.flow_lps)
    if isinstance(p, SprayPhase):
        index = next((i for i, q in enumerate(ctx.mission.phases) if q is p), -1)  # the mission's own phase: its rates
        return Spray(p, spray_rows(p, ctx), ctx.terrain_bounds, ctx.air_density_kgm3, ctx.no_spray_enu,
                     ctx.segment_rates.get(index))
    if isinstance(p, SprayerPhase):
        return SetSprayerFlow(p.flow_lps)
    if isinstance(p, LandPhase):
        return Land(p.descent_speed_mps, p.timeout_s)
    if isinstance(p, RtlPhase):
        return Rtl(p.return_altitude_agl_m, p.timeout_s)
    if isinstance(p, OpenLoopPhase):
        return OpenLoop(p, v.n_rotors)
    raise InputError(f"builtin autopilot: unsupported phase {type(p).__name__}")
