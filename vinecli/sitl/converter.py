"""What the phase -> mission-item converter (:func:`vinecli.phase_items.phases_to_items`) takes from a run's
context, for every firmware: the mission with the world's geofence when it has none of its own, and the
:class:`~vinecli.phase_items.PlanContext` (home, rows, terrain, nozzle flow, the vehicle's acceleration for
the spray plan's turns, the sprayer's pattern) in the firmware's latitude/longitude convention (``origin``)."""

from __future__ import annotations

from typing import Any

from vinecli.autopilot.base import AutopilotContext
from vinecli.phase_items import PlanContext
from vinecli.specs.mission import MissionSpec
from vinecli.specs.vehicle import VehicleSpec


def converter_inputs(ctx: AutopilotContext, origin: Any = None, *, firmware: str) -> tuple[MissionSpec, PlanContext]:
    """(mission, plan context) for ``ctx``; ``origin``: anything with ``enu_to_geodetic_fast`` (default the
    world's WGS84 origin); ``firmware`` is named in the converter's errors."""
    from vinecli.rows.plan import plan_accel

    v = ctx.vehicle
    pc = PlanContext(
        origin=origin if origin is not None else ctx.origin, home_enu=ctx.home_enu, vine_rows_enu=ctx.vine_rows_enu,
        terrain_height=ctx.terrain_height,
        nozzle_max_flow_lps=pump_max_flow_lps(v) or None,
        accel_mps2=plan_accel(v), firmware=firmware, vehicle=v, terrain_bounds=ctx.terrain_bounds,
        air_density=ctx.air_density_kgm3, no_spray_enu=ctx.no_spray_enu, segment_rates=dict(ctx.segment_rates),
        rate_items="switch" if firmware == "ArduPilot" else "actuator",
    )
    mission = ctx.mission
    if ctx.geofence is not None and mission.geofence is None:
        mission = mission.model_copy(update={"geofence": ctx.geofence})
    return mission, pc


def pump_max_flow_lps(vehicle: VehicleSpec) -> float:
    """The flow (L/s) of a firmware's pump output at 100 %: the maximum of the vehicle's pump model (the tank's
    ``nozzle_max_flow_lps``, :class:`vinecli.flight.pump.Pump`), 0 without a tank. PX4's DO_SET_ACTUATOR value and
    ArduPilot's sprayer pump output are duties of it; the flow command they give goes through the pump's lag."""
    return float(vehicle.tank.nozzle_max_flow_lps) if vehicle.tank is not None else 0.0


def takeoff_mass_kg(ctx: AutopilotContext) -> float:
    """The take-off mass a firmware is configured for, kg: the airframe as configured (payload included) plus
    the tank's fill at take-off (the mission's ``tank_fill_l``, else full) -- what an operator enters in the
    firmware's parameters, not something the autopilot senses."""
    v = ctx.vehicle
    if v.tank is None:
        return v.dry_mass()
    fill = ctx.mission.tank_fill_l
    return v.dry_mass() + v.liquid_mass(v.tank.capacity_l if fill is None else float(fill))


__all__ = ["converter_inputs", "pump_max_flow_lps", "takeoff_mass_kg"]
