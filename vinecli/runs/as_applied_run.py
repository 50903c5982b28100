"""The as-applied judgement of a run that flew segment rates (a canopy dose or a prescription map; docs/dose.md):
:func:`as_applied_for` evaluates it (:func:`vinecli.missions.as_applied.as_applied`) after the loop, adds its
metrics to the run's, its summary to ``summary.json`` (``as_applied``), and returns the outputs to write
(:mod:`vinecli.runs.as_applied_out`). ``summary.json`` ``as_applied.follows`` says how the autopilot followed the
rates: the built-in autopilot along the path, a firmware as its ``dose_follow`` event says (or not at all). The
deposition's dose faults (hot spots and thin stretches against one asked rate) do not apply to a dosed run.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from vinecli.missions.as_applied import AsApplied, DoseRun, as_applied
from vinecli.rows.segment_rates import SegmentRates
from vinecli.rows.spray_rate import phase_plan
from vinecli.specs.mission import SprayPhase, phase_rows

if TYPE_CHECKING:
    from vinecli.runs.as_applied_out import DoseOutputs
    from vinecli.sim.result import SimResult
    from vinecli.sim.setup import PreparedRun

__all__ = ["as_applied_for", "dose_run"]

#: what a backend does with segment rates when it says nothing (a firmware backend that cannot follow them)
NOT_FOLLOWED = "not followed: the autopilot flew the phase's mean rate"


def dose_run(run: PreparedRun, index: int) -> tuple[DoseRun, SprayPhase, Any]:
    """The :class:`DoseRun` of phase ``index`` of a prepared run (its plan as the autopilots fly it) and the plan."""
    ph = run.flight.phases[index]
    assert isinstance(ph, SprayPhase)
    world = run.world
    rows = phase_rows(ph, world.vine_rows_enu)
    fence = run.geofence.polygon_enu if run.geofence is not None else None
    b = world.terrain.bounds
    plan = phase_plan(ph, run.vehicle, rows, rows[0][0], fence_enu=fence, terrain_bounds=(b[0], b[1], b[2], b[3]),
                      air_density=float(world.air_density), no_spray=world.no_spray_enu)
    pump = run.vehicle.sprayer.pump
    lead = run.vehicle.sprayer.control.section_lead
    gnss = run.vehicle.sensors.gnss  # the autopilot switches on its GNSS-driven estimate (none on ground truth)
    noise = (0.0, 0.0) if run.flight.truth else (float(gnss.horizontal_noise_m), float(gnss.velocity_noise_mps))
    return DoseRun(index, rows, plan.flow_width_m, dict(plan.stretches), ph.speed_mps, pump.tau_up_s if lead else 0.0,
                   pump.tau_down_s if lead else 0.0, float(ph.canopy_width_m or world.canopy_width_m),
                   float(run.mission.record_rate_hz), *noise), ph, plan


def _events(result: SimResult, kind: str) -> list[dict[str, Any]]:
    return [dict(e.data) for e in result.events if e.kind == kind]


def _follows(result: SimResult, autopilot: str) -> dict[str, Any]:
    """How the autopilot followed the rates: the backend's ``dose_follow`` event, else the built-in autopilot's
    ``dose_plan`` (it follows the path), else :data:`NOT_FOLLOWED`."""
    said = _events(result, "dose_follow")
    if said:
        return said[-1]
    if _events(result, "dose_plan"):
        return {"autopilot": autopilot, "method": "flow along the path: each piece's litres per metre x ground speed, "
                                                  "led by the pump's lag", "limits": []}
    return {"autopilot": autopilot, "method": NOT_FOLLOWED, "limits": ["segment rates not followed"]}


def as_applied_for(run: PreparedRun, result: SimResult, metrics: dict[str, float], dep_doc: dict[str, Any] | None
                   ) -> DoseOutputs | None:
    """The as-applied outputs of a run with segment rates (None without): its metrics go into ``metrics``; the
    deposition's dose faults along the rows (``dep_doc`` rows), judged against one asked rate, are dropped and each
    row's covered share is of its prescription (half of it or more where the segment's rate is above 0), the
    as-applied log judges each segment against its own rate (module docstring)."""
    if not run.segment_rates or "phase_index" not in result.timeseries:
        return None
    from vinecli.runs.as_applied_out import DoseOutputs

    index, rates = next(iter(sorted(run.segment_rates.items())))
    dr, _, _ = dose_run(run, index)
    follows = _follows(result, run.mission.autopilot)
    plans = _events(result, "dose_plan") or ([follows["plan"]] if follows.get("plan") else [])
    out_of_range = sum(float(n.get("length_m", 0.0)) for n in (plans[-1].get("out_of_range", []) if plans else [])
                       if n.get("kind") in ("slowed", "over-dosed", "under-dosed"))
    dep = getattr(result, "deposition", None)
    aa: AsApplied = as_applied(result.timeseries, rates, dr, grid=dep.grid if dep is not None else None,
                               volume_l=dep.volume_l if dep is not None else None, out_of_range_m=out_of_range)
    metrics.update(aa.metrics)
    for row in (dep_doc or {}).get("rows") or []:  # judged against each segment's rate, not one asked rate
        row["faults"] = []
        b = aa.bins[row["row"]] if row["row"] < len(aa.bins) else None
        if b is not None and (b["prescribed"] > 0).any():
            p = b["prescribed"] > 0
            got = b["deposit"] if np.isfinite(b["deposit"]).any() else b["pump"]
            row["covered_fraction"] = float(np.mean(got[p] >= 0.5 * b["prescribed"][p]))
    return DoseOutputs(aa, rates, dr, summary_doc(aa, rates, follows, plans[-1] if plans else None),
                       dep.grid if dep is not None else None)


def summary_doc(aa: AsApplied, rates: SegmentRates, follows: dict[str, Any], plan: dict[str, Any] | None
                ) -> dict[str, Any]:
    """``summary.json`` ``as_applied``: the dose, how it was followed, the checks' figures, the product."""
    m = aa.metrics
    steps = [s for s in aa.steps if s.judged]
    return {
        "dose": rates.dose.label() if rates.dose is not None else None,
        "prescription": rates.prescription, "canopy_source": rates.canopy_source,
        "follows": follows, "plan": plan,
        "columns": {"prescribed_lpha": "the segment's prescribed rate, L/ha of ground",
                    "pump_lpha": "applied by the pump: delivered flow / (ground speed x track width), L/ha",
                    "deposit_lpha": "applied to the canopy band (row ± canopy width / 2) on the deposition map, L/ha"},
        "in_band_fraction": m["dose_in_band_fraction"], "in_band_fraction_deposit": m["dose_in_band_fraction_deposit"],
        "tolerance": aa.tolerance,
        "zones": aa.zones,
        "transitions": {"steps": len(steps), "over_bound": int(m["dose_transitions_over_bound"]),
                        "max_m": m["dose_transition_max_m"],
                        "max_over_bound_m": max((s.distance_m - s.bound_m for s in steps), default=math.nan)},
        "gaps": {"count": len(aa.gaps), "judged": sum(1 for g in aa.gaps if g["judged"]),
                 "sprayed": int(m["dose_gaps_sprayed"]), "litres": m["dose_gap_litres"]},
        "product": aa.product,
    }
