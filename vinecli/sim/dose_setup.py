"""Run set-up of spray phases dosed per canopy segment or by a prescription map (docs/dose.md).

A phase with ``lwa_dose_l``, ``trv_dose_l`` or ``prescription`` gets its :class:`~vinecli.rows.segment_rates.
SegmentRates` over its target rows: the world's canopy segments (``canopy_segments.json`` of ``world build``)
when it flies the world's rows (all, or some by index), else plain segments of its own rows (a map only); the map is read and checked
against those rows through the world's georeference (exit 2 for a bad map).

What is flown: the phase of the flight (:attr:`~vinecli.sim.setup.PreparedRun.flight`) gets the length-weighted
mean rate of its sprayed segments as its ``rate_lpha`` (its nominal flow and the sprayer's range check), and
``PreparedRun.segment_rates`` the segments themselves: the built-in autopilot follows them along the path
(:mod:`vinecli.rows.rate_path`), a firmware as far as it can (:mod:`vinecli.sitl.ardupilot.pump_rates`, PX4's
DO_SET_ACTUATOR items); the run's as-applied log judges what was delivered (:mod:`vinecli.runs.as_applied_run`).
"""

from __future__ import annotations

import dataclasses
import logging
from typing import TYPE_CHECKING

from vinecli.errors import InputError
from vinecli.rows.canopy_segments import CanopySegments, coarsen, plain_segments
from vinecli.rows.dose_units import DoseExpr
from vinecli.rows.segment_rates import SegmentRates, segment_rates
from vinecli.specs.mission import MissionSpec, SprayPhase, phase_rows

if TYPE_CHECKING:
    from vinecli.world.model import World

__all__ = ["resolve_dose_phases"]

log = logging.getLogger(__name__)


def _canopy(world: World, phase: SprayPhase, rows: list) -> CanopySegments:
    from vinecli.spray.canopy import row_spacing
    from vinecli.world.canopy_files import load_canopy_segments

    segs = load_canopy_segments(world.dir) if world.dir is not None else None
    if segs is not None and phase.rows == "world":
        return segs
    if segs is not None and phase.rows and isinstance(phase.rows[0], int):  # some of the world's rows, renumbered
        listed = [r for r in phase.rows if isinstance(r, int)]  # a row listed twice is flown (and dosed) twice
        return dataclasses.replace(segs, segments=tuple(dataclasses.replace(g, row=k) for k, r in enumerate(listed)
                                                        for g in segs.segments if g.row == r))
    return plain_segments(rows, segs.spacing_m if segs is not None else row_spacing(rows))


def resolve_dose_phases(mission: MissionSpec, world: World) -> tuple[MissionSpec, dict[int, SegmentRates]]:
    """``mission`` with every segment-dosed spray phase at its mean rate (``rate_lpha``, the dose fields cleared:
    what the flight's nominal flow is taken from) and the phases' segment rates by phase index (module docstring)."""
    if not any(isinstance(p, SprayPhase) and p.segment_dose for p in mission.phases):
        return mission, {}
    phases, out = list(mission.phases), {}
    for i, p in enumerate(phases):
        if not (isinstance(p, SprayPhase) and p.segment_dose):
            continue
        rows = phase_rows(p, world.vine_rows_enu)
        canopy = _canopy(world, p, rows)
        if p.segment_m is not None:  # the dose resolution the phase asks for
            canopy = coarsen(canopy, p.segment_m)
        name = f"phases.{i} (spray)"
        try:
            if p.prescription is not None:
                from vinecli.gis.georef import world_dir_georef
                from vinecli.gis.prescription import read_prescription

                pr = p.prescription
                m = read_prescription(pr.path, world_dir_georef(world.dir), rows, column=pr.column,
                                      default_lpha=pr.default_lpha, layer=pr.layer, units=pr.units)
                rates = segment_rates(canopy, rate_map=m.rates, prescription=m.summary(), rows=rows)
            else:
                dose = DoseExpr("lwa", p.lwa_dose_l, p.sides) if p.lwa_dose_l is not None else \
                    DoseExpr("trv", float(p.trv_dose_l or 0.0), p.sides)
                rates = segment_rates(canopy, dose=dose, rows=rows)
        except InputError:
            raise  # a bad map: the file and the problem
        except ValueError as exc:
            raise InputError(f"{name}: {exc}") from None
        mean = float(rates.summary()["rate_mean_lpha"])
        if not mean > 0:
            raise InputError(f"{name}: the dose gives no spray on any segment (no canopy measured?)")
        log.info("%s: segment rates %.1f-%.1f L/ha (mean %.1f L/ha)", name, rates.summary()["rate_min_lpha"],
                 rates.summary()["rate_max_lpha"], mean)
        phases[i] = SprayPhase.model_construct(**{**dict(p), "rate_lpha": mean, "lwa_dose_l": None, "trv_dose_l": None,
                                                  "prescription": None})
        out[i] = rates
    return mission.model_copy(update={"phases": phases}), out
