"""Preflight (arming) checks, PX4 commander style: the vehicle is not armed when one fails.

Pure functions (no PyBullet, no MAVLink), shared by the built-in autopilot (at arming) and
``vinecli world build`` (the spawn). World ENU, metres; altitudes relative to home.

* ``tilt``: tilted more than ``control.preflight_max_tilt_deg`` at rest (upside down on a slope).
* ``geofence_spawn`` / ``geofence_plan``: home or a planned path point outside the geofence or
  closer to it than the position-estimate uncertainty (:func:`fence_margins_m`: 3 σ of the
  GNSS noise horizontally and vertically), so that noise alone cannot breach the fence.
* ``plan_off_terrain``: a planned path point (or a spray row) outside the mapped terrain.
* ``estimator``: the estimator has not converged by ``control.preflight_timeout_s`` (checked by
  the autopilot itself, see :class:`~vinecli.autopilot.builtin.BuiltinAutopilot`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from vinecli.autopilot.geofence import Geofence
from vinecli.frames import Vec3
from vinecli.rows.plan import plan_rows
from vinecli.specs.mission import (
    GeofenceSpec,
    GotoPhase,
    MissionSpec,
    RtlPhase,
    SprayPhase,
    TakeoffPhase,
    WaypointsPhase,
    phase_rows,
)
from vinecli.specs.vehicle import VehicleSpec

#: the fence margin covers this many standard deviations of the position noise
MARGIN_SIGMAS = 3.0
#: a planned point may lie this far beyond the terrain's last sample (rows detected on the height
#: grid end a few cm past it), m
TERRAIN_EDGE_TOLERANCE_M = 0.1


@dataclass(frozen=True)
class PreflightFailure:
    """One failed check: ``check`` name, the measured ``value`` and its ``limit``, a sentence."""

    check: str
    value: float
    limit: float
    message: str


@dataclass(frozen=True)
class PlanPoint:
    """A point the mission will fly through: label (``phase 1 (goto)``), ENU x, y (m), z above home (m)."""

    label: str
    x: float
    y: float
    z_rel: float
    #: a headland turn or transit of a spray plan: checked against the fence only, since turns may run a
    #: little past the mapped terrain's edge (flown at the edge's height)
    turn: bool = False


def fence_margins_m(sigma_h_m: float, sigma_v_m: float) -> tuple[float, float]:
    """(horizontal, vertical) margin from the fence, m: ``MARGIN_SIGMAS`` times the position estimate's
    1-σ uncertainty (the GNSS noise for the autopilot's own estimator, 0 for a perfect one)."""
    return MARGIN_SIGMAS * sigma_h_m, MARGIN_SIGMAS * sigma_v_m


def check_tilt(tilt_rad: float, vehicle: VehicleSpec) -> PreflightFailure | None:
    """Tilt at rest (rad) against ``control.preflight_max_tilt_deg``."""
    limit = vehicle.control.preflight_max_tilt_deg
    deg = math.degrees(tilt_rad)
    if deg <= limit:
        return None
    return PreflightFailure("tilt", deg, limit, f"preflight check 'tilt': tilted {deg:.1f} deg at rest "
                                                f"(limit {limit:g} deg)")


def check_spawn_fence(fence: GeofenceSpec | None, home: Vec3, margin_h: float) -> PreflightFailure | None:
    """Home (ENU m) inside the fence's horizontal limits by at least ``margin_h`` m."""
    if fence is None or fence.action == "none":
        return None
    horiz, _ = Geofence(fence, home).clearance(home)
    if horiz >= margin_h:
        return None
    where = "outside the geofence" if horiz < 0 else "too close to the geofence"
    return PreflightFailure("geofence_spawn", horiz, margin_h,
                            f"preflight check 'geofence_spawn': spawn ({home[0]:.2f}, {home[1]:.2f}) is {where}: "
                            f"{horiz:.2f} m inside, needs {margin_h:.2f} m (position uncertainty)")


# parameters: keyword-only options, each with its default (the mission's world: fence, vehicle, terrain, air, no-spray zones); a caller names the ones it sets
def plan_points(mission: MissionSpec, home: Vec3, rows: Sequence[Sequence[tuple[float, float]]],
                terrain_height: Callable[[float, float], float] | None, landing_gear_m: float, *,
                fence: GeofenceSpec | None = None, accel_mps2: float | None = None, vehicle: VehicleSpec | None = None,
                terrain_bounds: tuple[float, float, float, float] | None = None,
                air_density: float = 1.225, no_spray: Sequence[Sequence[tuple[float, float]]] = ()) -> list[PlanPoint]:
    """The points the mission's phases fly to (z above home). A spray phase contributes the path the
    built-in spray phase flies: with ``vehicle`` its plan (:func:`~vinecli.rows.spray_rate.phase_plan`: the
    passes from the sprayer's pattern), else :func:`~vinecli.rows.plan.plan_rows` over its rows with headland
    turns for ``accel_mps2`` (its rows' points when no acceleration is given), from where the vehicle is,
    clipped to ``fence``, each at the spray height over the terrain."""
    pts: list[PlanPoint] = []
    x, y, z = home[0], home[1], 0.0
    for i, ph in enumerate(mission.phases):
        label = f"phase {i} ({ph.type})"
        if isinstance(ph, TakeoffPhase):
            z = ph.altitude_agl_m
            pts.append(PlanPoint(label, x, y, z))
        elif isinstance(ph, GotoPhase):
            x, y = float(ph.position_enu[0]), float(ph.position_enu[1])
            z = ph.altitude_agl_m if ph.altitude_agl_m is not None else z
            pts.append(PlanPoint(label, x, y, z))
        elif isinstance(ph, WaypointsPhase):
            for j, (wx, wy, wa) in enumerate(ph.waypoints):
                x, y, z = float(wx), float(wy), float(wa)
                pts.append(PlanPoint(f"{label} waypoint {j}", x, y, z))
        elif isinstance(ph, RtlPhase):
            z = max(z, ph.return_altitude_agl_m)
            pts.append(PlanPoint(label, x, y, z))
            x, y = home[0], home[1]
            pts.append(PlanPoint(label, x, y, z))
        elif isinstance(ph, SprayPhase):
            sel = [[(float(a), float(b)) for a, b in r] for r in phase_rows(ph, rows)]
            path = [(p, "row point", False) for r in sel for p in r]
            polygon = fence.polygon_enu if fence is not None and fence.polygon_enu else None
            plan = None
            if vehicle is not None and sel:
                from vinecli.rows.spray_rate import phase_plan

                plan = phase_plan(ph, vehicle, sel, (x, y), fence_enu=polygon, terrain_bounds=terrain_bounds,
                                  air_density=air_density, no_spray=no_spray)
            elif accel_mps2 is not None and sel:
                plan = plan_rows(sel, (x, y), speed_mps=ph.speed_mps, accel_mps2=accel_mps2, fence_enu=polygon,
                                 no_spray=no_spray)
            if plan is not None:
                path = [(p, "path point" if leg.spray else f"{leg.kind} point", not leg.spray)
                        for leg in plan.legs for p in leg.points]
            for (px, py), what, turn in path:
                ground = terrain_height(px, py) + landing_gear_m if terrain_height is not None else home[2]
                pts.append(PlanPoint(f"{label} {what}", px, py, ground + ph.height_agl_m - home[2], turn))
            if path:
                x, y = path[-1][0]
    return pts


def check_plan(points: Sequence[PlanPoint], fence: GeofenceSpec | None, home: Vec3, margins: tuple[float, float],
               terrain_bounds: tuple[float, float, float, float] | None) -> list[PreflightFailure]:
    """Every planned point inside the fence by the margins and, but for the turns of a spray plan, over the
    mapped terrain (first failure of each kind)."""
    out: list[PreflightFailure] = []
    if terrain_bounds is not None:
        tol = TERRAIN_EDGE_TOLERANCE_M
        xmin, ymin, xmax, ymax = terrain_bounds
        xmin, ymin, xmax, ymax = xmin - tol, ymin - tol, xmax + tol, ymax + tol
        for p in points:
            if not p.turn and not (xmin <= p.x <= xmax and ymin <= p.y <= ymax):
                out.append(PreflightFailure(
                    "plan_off_terrain", 0.0, 0.0,
                    f"preflight check 'plan_off_terrain': {p.label} at ({p.x:.2f}, {p.y:.2f}) is outside the terrain "
                    f"[{xmin + tol:.2f}, {ymin + tol:.2f}, {xmax - tol:.2f}, {ymax - tol:.2f}]"))
                break
    if fence is not None and fence.action != "none":
        gf = Geofence(fence, home)
        mh, mv = margins
        for p in points:
            horiz, vert = gf.clearance((p.x, p.y, home[2] + p.z_rel))
            if horiz < mh:
                value, need, where = horiz, mh, f"at ({p.x:.2f}, {p.y:.2f}) is {horiz:.2f} m inside the geofence"
            elif vert < mv:
                value, need, where = vert, mv, f"at {p.z_rel:.2f} m above home is {vert:.2f} m below the geofence ceiling"
            else:
                continue
            out.append(PreflightFailure("geofence_plan", value, need,
                                        f"preflight check 'geofence_plan': {p.label} {where}, needs {need:.2f} m"))
            break
    return out
