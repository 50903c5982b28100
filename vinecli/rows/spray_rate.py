"""Application rate (L/ha) <-> nozzle flow (L/s) for ``spray`` phases.

rate [L/ha] = 10 000 · q [L/s] / (v [m/s] · w [m]) with w the track width: the geometric swath of
the vehicle's nozzles at the phase height (:meth:`SprayerSpec.swath_m`), or the spacing of the
phase's rows when they are closer than the swath (a pass over every row then doses a band one row
spacing wide; the neighbouring passes overlap it, as a drone app's "track spacing"). The nozzle
height above the terrain is the phase height (skids above terrain, as ``height_agl_m``) + the
landing-gear height + the nozzle's z in body FLU (negative below the CoM).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from vinecli.rows.detect import row_spacing_m
from vinecli.specs.mission import MissionSpec, SprayPhase, phase_rows
from vinecli.specs.vehicle import VehicleSpec

__all__ = ["flow_for_rate", "nominal_rate_lpha", "nozzle_height_m", "phase_rows", "resolve_spray_rates",
           "spray_swath_m", "track_width_m"]

Rows = Sequence[Sequence[tuple[float, float]]]


def nozzle_height_m(vehicle: VehicleSpec, height_agl_m: float) -> float:
    """Mean nozzle height above the terrain when the skids fly ``height_agl_m`` above it, m."""
    nz = sum(n.position_m[2] for n in vehicle.sprayer.nozzles) / len(vehicle.sprayer.nozzles)
    return max(height_agl_m + vehicle.frame.landing_gear_height_m + nz, 0.0)


def spray_swath_m(vehicle: VehicleSpec, height_agl_m: float) -> float:
    """Geometric swath of the vehicle's nozzles flying at ``height_agl_m`` (skids above terrain), m."""
    return vehicle.sprayer.swath_m(nozzle_height_m(vehicle, height_agl_m))


def track_width_m(vehicle: VehicleSpec, phase: SprayPhase, rows: Rows = ()) -> float:
    """Width one pass doses, m: the swath, or the row spacing of ``rows`` (the phase's) when smaller."""
    swath = spray_swath_m(vehicle, phase.height_agl_m)
    spacing = row_spacing_m(rows) if len(rows) >= 2 else math.nan
    return min(swath, spacing) if math.isfinite(spacing) and spacing > 0 else swath


def flow_for_rate(rate_lpha: float, swath_m: float, speed_mps: float) -> float:
    """Nozzle flow (L/s) that applies ``rate_lpha`` over ``swath_m`` at ``speed_mps``."""
    return rate_lpha * swath_m * speed_mps / 10_000.0


def nominal_rate_lpha(phase: SprayPhase, vehicle: VehicleSpec, rows: Rows = ()) -> float:
    """The rate (L/ha) a spray phase asks for: its ``rate_lpha``, else 10 000 q / (v · track width);
    ``rows``: the phase's target rows (:func:`phase_rows`)."""
    if phase.rate_lpha is not None:
        return float(phase.rate_lpha)
    w = track_width_m(vehicle, phase, rows)
    return 10_000.0 * float(phase.flow_lps or 0.0) / (phase.speed_mps * w) if w > 0 else 0.0


def resolve_spray_rates(mission: MissionSpec, vehicle: VehicleSpec, world_rows: Rows = ()) -> MissionSpec:
    """``mission`` with every ``rate_lpha`` spray phase turned into its flow (both fields kept)."""
    if not any(isinstance(p, SprayPhase) and p.flow_lps is None for p in mission.phases):
        return mission
    phases = []
    for p in mission.phases:
        if isinstance(p, SprayPhase) and p.flow_lps is None:
            w = track_width_m(vehicle, p, phase_rows(p, world_rows))
            q = flow_for_rate(float(p.rate_lpha or 0.0), w, p.speed_mps)
            p = SprayPhase.model_construct(**{**dict(p), "flow_lps": q})
        phases.append(p)
    return mission.model_copy(update={"phases": phases})
