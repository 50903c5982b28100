"""The dose judged by default: checks every mission with a spray phase gets.

Unless the mission says ``dose: {check: false}``, a spraying mission is judged on the deposit along each
target row's planned stretch (:mod:`vinecli.missions.deposition_metrics`), with the bands of its ``dose``
(:class:`~vinecli.specs.mission.DoseSpec`):

* ``dose_row_rates``: every row's mean rate within ``rate_tolerance`` (±15 %) of the asked rate;
* ``dose_hot_spots``: no ``window_m`` (1 m) stretch above ``hot_ratio`` (1.3) x the asked rate;
* ``dose_gaps``: no such stretch below ``gap_ratio`` (0.6) x inside a planned stretch;
* ``dose_coverage``: at least ``coverage_min`` (98 %) of the planned stretches got half the asked rate;
* ``dose_drift``: at most ``drift_max`` (5 %) of the liquid outside the geofence (or the field);
* ``dose_no_spray``: at most ``no_spray_max`` (0.1 %) of the liquid in the world's no-spray zones (0 without zones).

A phase dosed per row segment (``lwa_dose_l``, ``trv_dose_l``, ``prescription``: docs/dose.md) has no one asked
rate: instead of the four rate checks above it is judged on its as-applied log (:mod:`vinecli.missions.as_applied`,
following Colaço et al. 2014 and Luck et al. 2010):

* ``dose_as_applied``: at least 90 % of the sprayed row length within ±10 % of its segment's rate (pump-delivered);
* ``dose_zone_error``: every zone's mean error within ±10 %;
* ``dose_transitions``: no rate step's transition distance beyond its bound (pump lag x speed);
* ``dose_gaps_sprayed``: no gap sprayed beyond the pump's run-down at its ends;
* ``dose_drift`` and ``dose_no_spray`` as above.

A mission check of the same name replaces the default one (its own bounds, windows, description).
"""

from __future__ import annotations

from typing import Any

from vinecli.specs.mission import CheckSpec, MissionSpec, SprayPhase

__all__ = ["DOSE_CHECKS", "default_checks", "default_dose_checks"]

#: names of the default dose checks
DOSE_CHECKS = ("dose_row_rates", "dose_hot_spots", "dose_gaps", "dose_coverage", "dose_drift", "dose_no_spray")
#: ... of a phase dosed per segment
SEGMENT_DOSE_CHECKS = ("dose_as_applied", "dose_zone_error", "dose_transitions", "dose_gaps_sprayed", "dose_drift",
                       "dose_no_spray")
#: as-applied tolerance and the share of the sprayed row length within it (Colaço et al. 2014; Luck et al. 2010)
AS_APPLIED_TOLERANCE = 0.10
AS_APPLIED_IN_BAND_MIN = 0.90


def default_checks(spec: MissionSpec, metrics: dict[str, Any]) -> list[CheckSpec]:
    """Every check a run gets by default: the dose checks (:func:`default_dose_checks`) and the spray budget's
    (:func:`vinecli.missions.budget_metrics.budget_default_checks`, from the run's ``metrics``)."""
    from vinecli.missions.budget_metrics import budget_default_checks

    return [*default_dose_checks(spec), *budget_default_checks(spec.checks, metrics)]


def default_dose_checks(spec: MissionSpec) -> list[CheckSpec]:
    """The dose checks ``spec`` gets by default (none without a spray phase or with ``dose.check`` false), without
    those the mission defines itself (same name)."""
    if not spec.dose.check or not any(isinstance(p, SprayPhase) for p in spec.phases):
        return []
    d = spec.dose
    w = f"{d.window_m:g} m"
    if any(isinstance(p, SprayPhase) and p.segment_dose for p in spec.phases):
        checks = [*_segment_dose_checks(), *_field_checks(spec)]
        own = {c.name for c in spec.checks}
        return [c for c in checks if c.name not in own]
    checks = [
        CheckSpec(name="dose_row_rates", quantity="metric:row_rate_error_max", op="<=", bound=d.rate_tolerance,
                  description=f"every row's mean rate within ±{d.rate_tolerance:.0%} of the asked rate (default dose check)"),
        CheckSpec(name="dose_hot_spots", quantity="metric:dose_window_ratio_max", op="<=", bound=d.hot_ratio,
                  description=f"no {w} stretch along a row above {d.hot_ratio:g}x the asked rate (default dose check)"),
        CheckSpec(name="dose_gaps", quantity="metric:dose_window_ratio_min", op=">=", bound=d.gap_ratio,
                  description=f"no {w} stretch of a planned row stretch below {d.gap_ratio:g}x the asked rate "
                              "(default dose check)"),
        CheckSpec(name="dose_coverage", quantity="metric:row_coverage_fraction", op=">=", bound=d.coverage_min,
                  description=f"{d.coverage_min:.0%} of the planned row stretches got half the asked rate or more "
                              "(default dose check)"),
        *_field_checks(spec),
    ]
    own = {c.name for c in spec.checks}
    return [c for c in checks if c.name not in own]


def _field_checks(spec: MissionSpec) -> list[CheckSpec]:
    d = spec.dose
    return [
        CheckSpec(name="dose_drift", quantity="metric:drift_outside_fence_fraction", op="<=", bound=d.drift_max,
                  description=f"at most {d.drift_max:.0%} of the liquid outside the geofence (default dose check)"),
        CheckSpec(name="dose_no_spray", quantity="metric:deposit_in_no_spray_fraction", op="<=", bound=d.no_spray_max,
                  description=f"at most {d.no_spray_max:.1%} of the liquid in the no-spray zones (default dose check)"),
    ]


def _segment_dose_checks() -> list[CheckSpec]:
    tol = f"±{AS_APPLIED_TOLERANCE:.0%}"
    return [
        CheckSpec(name="dose_as_applied", quantity="metric:dose_in_band_fraction", op=">=", bound=AS_APPLIED_IN_BAND_MIN,
                  description=f"{AS_APPLIED_IN_BAND_MIN:.0%} of the sprayed row length within {tol} of its segment's "
                              "rate, as the pump delivered it (default dose check, as-applied)"),
        CheckSpec(name="dose_zone_error", quantity="metric:dose_zone_error_max", op="<=", bound=AS_APPLIED_TOLERANCE,
                  description=f"every zone's mean rate within {tol} of its prescription (default dose check, as-applied)"),
        CheckSpec(name="dose_transitions", quantity="metric:dose_transitions_over_bound", op="<=", bound=0.0,
                  description="every rate step within its transition bound (pump lag x speed; default dose check)"),
        CheckSpec(name="dose_gaps_sprayed", quantity="metric:dose_gaps_sprayed", op="<=", bound=0.0,
                  description="no gap sprayed beyond the pump's run-down at its ends (default dose check)"),
    ]
