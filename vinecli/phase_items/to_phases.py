"""MAVLink mission items -> mission phases a built-in autopilot flies (an uploaded mission, a plan file).

=====  ======================  ====================================================
cmd    MAVLink                 phase
=====  ======================  ====================================================
22     NAV_TAKEOFF             takeoff to the item's altitude (default when it has none)
16     NAV_WAYPOINT            goto the position (acceptance p2, yaw p4); p1 > 0 adds a hold
19     NAV_LOITER_TIME         goto the position, hold p1 s
93     NAV_DELAY / 112         hold p1 s
178    DO_CHANGE_SPEED         speed (p2, m/s) of the following gotos
187    DO_SET_ACTUATOR         sprayer: p1 = fraction of the nozzle's maximum flow (NaN unchanged)
183    DO_SET_SERVO            sprayer on the pump's output: PWM 1000..2000 µs -> 0..1 of the maximum flow
216    DO_SPRAYER              sprayer: p1 1 on, 0 off
21     NAV_LAND                goto the position (if given), land
20     NAV_RETURN_TO_LAUNCH    rtl
=====  ======================  ====================================================

Altitudes: relative frames (3, 6) are above home; absolute ones (0, 5) are AMSL minus home. Other
commands are skipped (a vehicle endpoint refuses them at upload:
:func:`vinecli.mavlink.mission_items.check_item`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from vinecli.frames import heading_ned_to_yaw_enu
from vinecli.geo import GeoOrigin
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.mission_items import MissionItem, degE7_to_enu
from vinecli.phase_items.sprayer import sprayer_fraction
from vinecli.specs.mission import GotoPhase, HoldPhase, LandPhase, RtlPhase, SprayerPhase, TakeoffPhase

__all__ = ["items_to_phases"]


def items_to_phases(
    items: Sequence[MissionItem], origin: GeoOrigin, home_alt_amsl: float, nozzle_max_flow_lps: float | None,
    takeoff_alt_default: float = 2.5, sprayer_servo: int = 9,
) -> tuple[list[object], list[int]]:
    """Phases flying ``items`` and, per phase, the index of the item it comes from (module doc).

    ``sprayer_servo``: the DO_SET_SERVO output number that drives the pump (ArduPilot style).
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
                yaw = math.degrees(heading_ned_to_yaw_enu(math.radians(it.param4) - origin.convergence_rad))
            accept = it.param2 if c == M.CMD_NAV_WAYPOINT and it.param2 > 0 else 0.5
            z = rel(it) if math.isfinite(it.z) else None
            if has_pos(it):
                phases.append(GotoPhase(position_enu=(x, y), altitude_agl_m=z, speed_mps=speed, acceptance_radius_m=accept,
                                        yaw_deg=yaw))
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
            u = sprayer_fraction(it, servo=sprayer_servo)
            if u is None:
                continue
            phases.append(SprayerPhase(flow_lps=u * nozzle))
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
