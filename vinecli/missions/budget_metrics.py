"""Spray-budget metrics of a run and the default checks on them (docs/budget.md).

Metrics (whole run; summary.json ``metrics``, ``metric:<name>`` in checks) are registered in
:data:`vinecli.missions.metrics.METRICS`. Default checks, added to a spraying run's checks unless
the mission has its own check on the same quantity (which then replaces the default):

* ``budget_drift_5m``: sedimenting drift 5 m downwind of the last row at most 3.62 % of the applied
  rate: the German basic drift value for vineyards in full leaf (late vines, 90th percentile of one
  application; Rautmann, Streloke & Winkler 2001, Mitt. Biol. Bundesanst. 383:133), the ground
  air-blast sprayer's reference that Herbst et al. 2023 measured drone drift against;
* ``budget_canopy_share``: at least 5 % of the emitted volume on the canopy, when the world has one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from vinecli.specs.mission import CheckSpec

__all__ = ["BUDGET_METRICS", "DEFAULT_CANOPY_SHARE_MIN", "DEFAULT_DRIFT_5M_MAX_PCT", "budget_default_checks",
           "budget_metrics"]

DRIFT_METRIC_DISTANCES = (1, 3, 5, 10, 15, 20)
DEFAULT_DRIFT_5M_MAX_PCT = 3.62
DEFAULT_CANOPY_SHARE_MIN = 0.05

#: name -> (unit, description); registered in vinecli.missions.metrics.METRICS
BUDGET_METRICS: dict[str, tuple[str, str]] = {
    "budget_canopy_fraction": ("1", "Share of the emitted volume captured by the canopy (the rows' hedges)"),
    "budget_ground_in_field_fraction": ("1", "Share of the emitted volume on the ground inside the field"),
    "budget_ground_off_field_fraction": ("1", "Share of the emitted volume on the ground outside the field, within "
                                              "the drift domain (sedimenting drift)"),
    "budget_airborne_out_fraction": ("1", "Share of the emitted volume leaving the drift domain airborne"),
    "budget_evaporated_fraction": ("1", "Share of the emitted volume evaporated in flight"),
    "budget_balance_error": ("1", "|1 - sum of the five budget fractions|"),
    "budget_canopy_deposit_ulpcm2": ("µL/cm²", "Canopy deposit per one-sided leaf area, all rows"),
    "budget_canopy_deposit_ulpcm2_per_lpha": ("µL/cm² per L/ha", "Canopy deposit per leaf area per applied L/ha"),
    "budget_lai": ("1", "Leaf area index of the field's canopy (leaf area per ground area)"),
    **{f"budget_drift_{d}m_percent": ("%", f"Sedimenting drift {d} m downwind of the last row, % of the applied rate")
       for d in DRIFT_METRIC_DISTANCES},
}


def budget_metrics(budget: Any, canopy: Any, applied_lpha: float) -> dict[str, float]:
    """The :data:`BUDGET_METRICS` of a :class:`~vinecli.spray.budget.SprayBudget`."""
    fr = budget.fractions
    m = {f"budget_{k}_fraction": float(v) for k, v in fr.items()}
    m["budget_balance_error"] = float(budget.balance_error)
    area = sum(canopy.leaf_area_m2(i) for i in range(len(canopy.hedges))) if canopy is not None else 0.0
    dep = 100.0 * budget.canopy_l / area if area > 0 else math.nan
    m["budget_canopy_deposit_ulpcm2"] = dep
    m["budget_canopy_deposit_ulpcm2_per_lpha"] = dep / applied_lpha if applied_lpha > 0 else math.nan
    m["budget_lai"] = float(canopy.lai()) if canopy is not None else math.nan
    for d in DRIFT_METRIC_DISTANCES:
        m[f"budget_drift_{d}m_percent"] = float(budget.drift_at(float(d)))
    return m


def budget_default_checks(checks: Sequence[CheckSpec], metrics: dict[str, Any]) -> list[CheckSpec]:
    """The default budget checks that apply (see the module doc) and that ``checks`` (the mission's) do not
    override."""
    used = {c.quantity for c in checks}
    out: list[CheckSpec] = []
    drift = metrics.get("budget_drift_5m_percent")
    if isinstance(drift, (int, float)) and math.isfinite(drift) and "metric:budget_drift_5m_percent" not in used:
        out.append(CheckSpec(name="budget_drift_5m", quantity="metric:budget_drift_5m_percent", op="<=",
                             bound=DEFAULT_DRIFT_5M_MAX_PCT,
                             description="drift 5 m downwind at most the basic drift value of late vines "
                                         "(Rautmann et al. 2001; default, overridable)"))
    deposit = metrics.get("budget_canopy_deposit_ulpcm2")  # finite when the world's canopy has leaves
    if isinstance(deposit, (int, float)) and math.isfinite(deposit) and "metric:budget_canopy_fraction" not in used:
        out.append(CheckSpec(name="budget_canopy_share", quantity="metric:budget_canopy_fraction", op=">=",
                             bound=DEFAULT_CANOPY_SHARE_MIN,
                             description="at least 5 % of the spray on the canopy (default, overridable)"))
    return out
