"""Spray phases against the vehicle's sprayer: the plan, the flow of the asked rate, the pump's range.

rate [L/ha] = 10 000 · q [L/s] / (v [m/s] · w [m]) with w the track width of the plan's passes
(:attr:`~vinecli.rows.plan.RowPlan.flow_width_m`): the lane spacing of evenly overlapped passes, or
the single-pass width that doses a row's canopy band when each row is its own pass, both from the
effective swath of the vehicle at the phase's height and speed (:mod:`vinecli.spray.swath`), not
from the cone geometry. The flow of a phase is what the pump delivers at the phase's cruise speed;
in flight the built-in autopilot scales it with the ground speed (litres per metre = q / v).

:func:`resolve_spray_rates` turns every ``rate_lpha`` phase into its flow and checks it against the
sprayer's flow range (pump maximum, nozzle pressure range): a rate or speed the sprayer cannot
deliver, or a speed above the vehicle's top speed (``control.max_vel_xy``), is refused with the numbers
(InputError, exit 2), or flown slower when the phase says ``allow_slower``; so are target rows of no length or
none left inside the fence. The nozzle height above the terrain is the phase height (skids above terrain, as
``height_agl_m``) + the landing-gear height + the nozzle's z in body FLU (negative below the CoM).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

from vinecli.errors import InputError
from vinecli.rows.plan import RowPlan, plan_accel, plan_rows
from vinecli.specs.mission import MissionSpec, SprayPhase, phase_rows
from vinecli.specs.vehicle import VehicleSpec

if TYPE_CHECKING:
    from vinecli.spray.swath import SwathPattern

__all__ = ["DEFAULT_BAND_M", "flow_for_rate", "nominal_rate_lpha", "nozzle_height_m", "phase_plan", "phase_rows",
           "resolve_spray_rates", "spray_pattern", "spray_swath_m"]

Rows = Sequence[Sequence[tuple[float, float]]]
#: canopy band a row is dosed on when neither the phase nor the world says (the world spec's default)
DEFAULT_BAND_M = 0.6


def nozzle_height_m(vehicle: VehicleSpec, height_agl_m: float) -> float:
    """Mean nozzle height above the terrain when the skids fly ``height_agl_m`` above it, m."""
    nz = sum(n.position_m[2] for n in vehicle.sprayer.nozzles) / len(vehicle.sprayer.nozzles)
    return max(height_agl_m + vehicle.frame.landing_gear_height_m + nz, 0.0)


def spray_swath_m(vehicle: VehicleSpec, height_agl_m: float) -> float:
    """Geometric swath of the vehicle's nozzles flying at ``height_agl_m`` (skids above terrain), m."""
    return vehicle.sprayer.swath_m(nozzle_height_m(vehicle, height_agl_m))


def flow_for_rate(rate_lpha: float, swath_m: float, speed_mps: float) -> float:
    """Nozzle flow (L/s) that applies ``rate_lpha`` over ``swath_m`` at ``speed_mps``."""
    return rate_lpha * swath_m * speed_mps / 10_000.0


@functools.lru_cache(maxsize=16)
def _pattern(vehicle_json: str, height_agl_m: float, speed_mps: float, air_density: float,
             crosswind_mps: float = 0.0) -> SwathPattern:
    from vinecli.spray.swath import swath_pattern

    return swath_pattern(VehicleSpec.model_validate_json(vehicle_json), height_agl_m, speed_mps, air_density=air_density,
                         crosswind_mps=crosswind_mps)


def spray_pattern(vehicle: VehicleSpec, height_agl_m: float, speed_mps: float, air_density: float = 1.225,
                  crosswind_mps: float = 0.0) -> SwathPattern:
    """The vehicle's pass pattern and effective swath at a spray height and speed, in calm air or a crosswind (m/s,
    towards the left of the pass) (cached)."""
    return _pattern(vehicle.model_dump_json(), float(height_agl_m), float(speed_mps), float(air_density),
                    round(float(crosswind_mps), 2))


def plan_crosswind_mps(phase: SprayPhase, rows: Rows) -> float:
    """The phase's planning wind (``plan_wind_enu``) across its rows, m/s towards the left of the rows' direction (the
    planner's across coordinate); 0 without one."""
    if phase.plan_wind_enu is None or not rows:
        return 0.0
    from vinecli.rows.plan import row_direction

    ux, uy = row_direction(rows)
    return float(-uy * phase.plan_wind_enu[0] + ux * phase.plan_wind_enu[1])


# parameters: keyword-only options, each with its default (the world the phase flies in: fence, terrain, air, climb, no-spray zones); a caller names the ones it sets
def phase_plan(phase: SprayPhase, vehicle: VehicleSpec, rows: Rows, start_xy: tuple[float, float], *,
               fence_enu: Sequence[tuple[float, float]] | None = None,
               terrain_bounds: tuple[float, float, float, float] | None = None, air_density: float = 1.225,
               climb: tuple[float, float, float] | None = None, no_spray: Rows = ()) -> RowPlan:
    """THE plan of a spray phase over ``rows`` (its target rows) from ``start_xy``: passes laid out from the
    vehicle's pattern at the phase's height and speed and run on past the row ends by its footprint and the pump's
    ramp (speed x time constant), turns for the vehicle's acceleration, clipped to the fence (1 m margin), the
    terrain and the world's no-spray zones ``no_spray`` less the footprint's clearance (:mod:`vinecli.rows.no_spray`).
    The built-in autopilot flies it, the run set-up takes its flow from it, the exports and the deposition
    evaluation use it."""
    pattern = spray_pattern(vehicle, phase.height_agl_m, phase.speed_mps, air_density, plan_crosswind_mps(phase, rows))
    band = phase.canopy_width_m if phase.canopy_width_m is not None else DEFAULT_BAND_M
    pump = vehicle.sprayer.pump
    ramp = phase.speed_mps * max(pump.tau_up_s, pump.tau_down_s)  # the flow's ramp, spread by the pump's lag
    return plan_rows(rows, start_xy, speed_mps=phase.speed_mps, accel_mps2=plan_accel(vehicle), fence_enu=fence_enu,
                     terrain_bounds=terrain_bounds, climb=climb, pattern=pattern, band_m=band, end_margin_m=ramp,
                     no_spray=no_spray)


def nominal_rate_lpha(phase: SprayPhase, vehicle: VehicleSpec, plan: RowPlan) -> float:
    """The rate (L/ha) a spray phase asks for: its ``rate_lpha``, else 10 000 q / (v · the plan's track width)."""
    if phase.rate_lpha is not None:
        return float(phase.rate_lpha)
    w = plan.flow_width_m
    return 10_000.0 * float(phase.flow_lps or 0.0) / (phase.speed_mps * w) if w > 0 else math.nan


def _check_range(i: int, p: SprayPhase, vehicle: VehicleSpec, width: float) -> SprayPhase:
    """``p`` (flow resolved) within the sprayer's flow range and above its minimum speed: else slower when allowed,
    else InputError naming the numbers."""
    name = f"phases.{i} (spray)"
    ctl = vehicle.sprayer.control
    if p.speed_mps < ctl.speed_min_mps:
        raise InputError(f"{name}: speed {p.speed_mps:g} m/s is below the sprayer's minimum {ctl.speed_min_mps:g} m/s "
                         f"({vehicle.name}: sprayer.control.speed_min_mps): it would never switch on")
    top = float(vehicle.control.max_vel_xy)
    if p.speed_mps > top * (1 + 1e-9):  # the velocity controller would clamp it: the plan's turns and times are wrong
        if p.allow_slower:
            q = float(p.flow_lps or 0.0) * top / p.speed_mps
            return _check_range(i, SprayPhase.model_construct(**{**dict(p), "speed_mps": top, "flow_lps": q}), vehicle,
                                width)
        raise InputError(f"{name}: speed {p.speed_mps:g} m/s is above {vehicle.name}'s top speed {top:g} m/s "
                         "(control.max_vel_xy): fly at most that (or allow_slower: true)")
    tank = vehicle.tank
    if tank is None:
        raise InputError(f"{name}: vehicle {vehicle.name!r} has no tank to spray from")
    lo, hi = vehicle.sprayer.flow_range_lps(tank.nozzle_max_flow_lps)
    q = float(p.flow_lps or 0.0)
    per_m = q / p.speed_mps
    what = (f"{p.rate_lpha:g} L/ha over a {width:.2f} m track" if p.rate_lpha is not None else f"{q:g} L/s")
    if q > hi * (1 + 1e-9):
        v_max = hi / per_m
        if p.allow_slower and v_max >= ctl.speed_min_mps:
            return SprayPhase.model_construct(**{**dict(p), "speed_mps": v_max, "flow_lps": hi})
        raise InputError(f"{name}: {what} at {p.speed_mps:g} m/s needs {q:.4f} L/s; {vehicle.name}'s sprayer delivers at "
                         f"most {hi:.4f} L/s: fly at most {v_max:.2f} m/s (or allow_slower: true)")
    if q < lo * (1 - 1e-9):
        raise InputError(f"{name}: {what} at {p.speed_mps:g} m/s needs {q:.4f} L/s; {vehicle.name}'s nozzles need at "
                         f"least {lo:.4f} L/s (pressure range {vehicle.sprayer.pressure_range_bar} bar): fly at least "
                         f"{lo / per_m:.2f} m/s or ask for a higher rate")
    return p


def _check_rows(i: int, rows: Rows) -> None:
    """InputError when a target row cannot be sprayed: fewer than two points, or no length."""
    for k, r in enumerate(rows):
        length = sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(r[:-1], r[1:], strict=True))
        if len(r) < 2 or not length > 0.0:
            raise InputError(f"phases.{i} (spray): target row {k} is {length:g} m long ({len(r)} point(s)): "
                             "a row needs two distinct points")


# parameters: the plan's inputs (mission, vehicle, rows, fence, terrain, air, band, no-spray rows) and the wind the
# passes are displaced against
def resolve_spray_rates(mission: MissionSpec, vehicle: VehicleSpec, world_rows: Rows = (), *,
                        fence_enu: Sequence[tuple[float, float]] | None = None,
                        terrain_bounds: tuple[float, float, float, float] | None = None,
                        air_density: float = 1.225, canopy_width_m: float = DEFAULT_BAND_M,
                        no_spray: Rows = (), wind_xy: tuple[float, float] | None = None) -> MissionSpec:
    """``mission`` with every spray phase's canopy band resolved (the world's ``canopy_width_m`` unless the phase
    gives one), its planning wind resolved (the mission's mean wind unless the phase gives one: the passes are
    displaced upwind by the plume's drift), every ``rate_lpha`` turned into the flow of its plan's track width at the
    phase's speed (both fields kept), and the flow checked against the sprayer (see the module docstring).
    ``wind_xy``: the mean horizontal wind of the run (m/s ENU; default: the mission's law's, else calm)."""
    if not any(isinstance(p, SprayPhase) for p in mission.phases):
        return mission
    if wind_xy is None:
        wind_xy = mission.wind.mean_horizontal_enu() if mission.wind is not None else (0.0, 0.0)
    wind = (float(wind_xy[0]), float(wind_xy[1]))
    phases = []
    for i, p in enumerate(mission.phases):
        if isinstance(p, SprayPhase):
            if p.canopy_width_m is None:
                p = SprayPhase.model_construct(**{**dict(p), "canopy_width_m": float(canopy_width_m)})
            if p.plan_wind_enu is None:
                p = SprayPhase.model_construct(**{**dict(p), "plan_wind_enu": wind})
            rows = phase_rows(p, world_rows)
            _check_rows(i, rows)
            for _ in range(3) if rows else ():  # a slower speed changes the pattern a little: plan again
                plan = phase_plan(p, vehicle, rows, rows[0][0], fence_enu=fence_enu, terrain_bounds=terrain_bounds,
                                  air_density=air_density, no_spray=no_spray)
                if not plan.legs:
                    raise InputError(f"phases.{i} (spray): no row left to spray inside the geofence and the terrain")
                if p.rate_lpha is not None:
                    q = flow_for_rate(float(p.rate_lpha), plan.flow_width_m, p.speed_mps)
                    p = SprayPhase.model_construct(**{**dict(p), "flow_lps": q})
                checked = _check_range(i, p, vehicle, plan.flow_width_m)
                if checked.speed_mps == p.speed_mps:
                    break
                p = checked
        phases.append(p)
    return mission.model_copy(update={"phases": phases})
