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

Altitudes: relative frames (3, 6) and terrain frames (10, 11, taken as above home) are above home; absolute
ones (0, 5) are AMSL minus home. Other commands are skipped (a vehicle endpoint refuses them at upload:
:func:`vinecli.mavlink.mission_items.check_item`; a plan file's reader names them:
:mod:`vinecli.missions.qgc_import`).

``compact`` gives the phases a person writes (a plan file's import): consecutive waypoints at one speed and
acceptance, without yaw or hold, become one ``waypoints`` phase, and a loiter or landing where the vehicle
already is (within 0.5 m, the acceptance radius, and 0.1 m up) gets no goto before it. Without it (a vehicle
endpoint) each position item is a phase of its own, so the mission's current item can be followed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from vinecli.frames import heading_ned_to_yaw_enu, wrap_pi
from vinecli.geo import GeoOrigin
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.mission_items import MissionItem, item_enu
from vinecli.phase_items.sprayer_command import sprayer_fraction
from vinecli.specs.mission import (
    GotoPhase,
    HoldPhase,
    LandPhase,
    RtlPhase,
    SprayerPhase,
    TakeoffPhase,
    WaypointsPhase,
)

__all__ = ["items_to_phases"]

_RELATIVE_FRAMES = (3, 6, 10, 11)
_HERE_M, _HERE_UP_M = 0.5, 0.1  # compact: a position item this close to where the vehicle is needs no goto


class _Phases:
    """Phases under construction, the item each comes from, and (compact) the open waypoint run and the position
    the vehicle is at after them (ENU x, y, altitude above home; None unknown)."""

    def __init__(self, compact: bool) -> None:
        self.compact = compact
        self.phases: list[object] = []
        self.src: list[int] = []
        self.run: list[tuple[float, float, float]] = []
        self.run_key: tuple[float, float] = (0.0, 0.0)
        self.run_src = -1
        self.pos: tuple[float, float, float | None] | None = None

    def add(self, phase: object, k: int) -> None:
        self.flush()
        self.phases.append(phase)
        self.src.append(k)

    def flush(self) -> None:
        if self.run:
            self.phases.append(WaypointsPhase(waypoints=self.run, speed_mps=self.run_key[0],
                                              acceptance_radius_m=self.run_key[1]))
            self.src.append(self.run_src)
            self.run = []

    def waypoint(self, x: float, y: float, z: float, speed: float, accept: float, k: int) -> None:
        """A plain waypoint (compact): joins the open run when it flies at the same speed and acceptance."""
        if self.run and self.run_key != (speed, accept):
            self.flush()
        if not self.run:
            self.run_key, self.run_src = (speed, accept), k
        self.run.append((x, y, z))
        self.pos = (x, y, z)

    def goto(self, x: float, y: float, z: float | None, speed: float | None, accept: float, yaw: float | None,
             k: int) -> None:
        """A goto, left out (compact) when the vehicle is already there."""
        p = self.pos
        if self.compact and p is not None and yaw is None and math.hypot(x - p[0], y - p[1]) <= _HERE_M \
                and (z is None or p[2] is None or abs(z - p[2]) <= _HERE_UP_M):
            return
        self.add(GotoPhase(position_enu=(x, y), altitude_agl_m=z, speed_mps=speed, acceptance_radius_m=accept,
                           yaw_deg=yaw), k)
        self.pos = (x, y, z if z is not None else (self.pos[2] if self.pos is not None else None))


# parameters: the items and their georeference, then conversion options with their defaults (QGC's sprayer
# servo, degrees, compact legs, speed)
def items_to_phases(
    items: Sequence[MissionItem], origin: GeoOrigin, home_alt_amsl: float, nozzle_max_flow_lps: float | None,
    takeoff_alt_default: float = 2.5, sprayer_servo: int = 9, *, degrees: bool = False, sprayer_on: float = 1.0,
    compact: bool = False, speed_mps: float | None = None,
) -> tuple[list[object], list[int]]:
    """Phases flying ``items`` and, per phase, the index of the item it comes from (module doc).

    ``sprayer_servo``: the DO_SET_SERVO output number that drives the pump (ArduPilot style); ``sprayer_on``: the
    fraction of the nozzle maximum DO_SPRAYER "on" stands for; ``degrees``: item x/y are float degrees (a plan
    file, :func:`~vinecli.mavlink.mission_items.item_enu`), not degE7; ``compact``: see the module doc;
    ``speed_mps``: the speed before the first DO_CHANGE_SPEED (None: the autopilot's; compact needs one, default
    2 m/s).
    """
    out = _Phases(compact)
    speed = speed_mps
    nozzle = nozzle_max_flow_lps or 0.0

    def rel(it: MissionItem) -> float:
        return it.z if it.frame in _RELATIVE_FRAMES else it.z - home_alt_amsl

    def has_pos(it: MissionItem) -> bool:
        return not (it.x == 0 and it.y == 0)

    for k, it in enumerate(items):
        c = it.command
        if c == M.CMD_NAV_TAKEOFF:
            alt = rel(it) if math.isfinite(it.z) and rel(it) > 0 else takeoff_alt_default
            out.add(TakeoffPhase(altitude_agl_m=alt), k)
            if has_pos(it):
                out.pos = (*item_enu(origin, it.x, it.y, degrees=degrees), alt)
        elif c in (M.CMD_NAV_WAYPOINT, M.CMD_NAV_LOITER_TIME):
            x, y = item_enu(origin, it.x, it.y, degrees=degrees)
            yaw = None
            if c == M.CMD_NAV_WAYPOINT and math.isfinite(it.param4):
                yaw = math.degrees(wrap_pi(heading_ned_to_yaw_enu(math.radians(it.param4)) - origin.convergence_rad))
            accept = it.param2 if c == M.CMD_NAV_WAYPOINT and it.param2 > 0 else 0.5
            z = rel(it) if math.isfinite(it.z) else None
            hold = it.param1  # hold / loiter time at the waypoint, s
            if has_pos(it) and compact and c == M.CMD_NAV_WAYPOINT and yaw is None and z is not None:
                out.waypoint(x, y, z, speed if speed is not None else 2.0, accept, k)
            elif has_pos(it):
                out.goto(x, y, z, speed, accept, yaw, k)
            if hold > 0:
                out.add(HoldPhase(duration_s=hold), k)
        elif c in (M.CMD_NAV_DELAY, M.CMD_CONDITION_DELAY):
            if it.param1 > 0:
                out.add(HoldPhase(duration_s=it.param1), k)
        elif c == M.CMD_DO_CHANGE_SPEED:
            if it.param2 > 0:
                speed = it.param2
        elif c in (M.CMD_DO_SET_ACTUATOR, M.CMD_DO_SET_SERVO, M.CMD_DO_SPRAYER):
            u = sprayer_fraction(it, servo=sprayer_servo, sprayer_on=sprayer_on)
            if u is not None:
                out.add(SprayerPhase(flow_lps=u * nozzle), k)
        elif c == M.CMD_NAV_LAND:
            if has_pos(it):
                x, y = item_enu(origin, it.x, it.y, degrees=degrees)
                out.goto(x, y, None, speed, 0.5, None, k)
            out.add(LandPhase(), k)
        elif c == M.CMD_NAV_RETURN_TO_LAUNCH:
            out.add(RtlPhase(), k)
            out.pos = None  # home: not an item's position
    out.flush()
    return out.phases, out.src
