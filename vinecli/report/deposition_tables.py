"""The deposition and budget metrics of spray runs as a Markdown table and JUnit properties (docs/deposition.md,
docs/budget.md), and their operations figures (summary.json ``operations``) as a second table."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["DEPOSITION_COLUMNS", "OPERATIONS_COLUMNS", "deposition_markdown", "deposition_properties"]

#: metric -> (header, format)
DEPOSITION_COLUMNS: dict[str, tuple[str, str]] = {
    "deposit_emitted_l": ("emitted, L", "{:.3f}"),
    "nominal_rate_lpha": ("asked, L/ha", "{:.1f}"),
    "mean_rate_lpha_on_rows": ("mean on rows, L/ha", "{:.1f}"),
    "deposit_cv_on_rows": ("CV on rows", "{:.0%}"),
    "row_coverage_fraction": ("rows covered", "{:.0%}"),
    "row_rate_error_max": ("worst row", "±{:.0%}"),
    "dose_window_ratio_max": ("hottest 1 m", "{:.2f}x"),
    "dose_window_ratio_min": ("thinnest 1 m", "{:.2f}x"),
    "deposit_on_rows_fraction": ("in row bands", "{:.0%}"),
    "drift_outside_fence_fraction": ("outside fence", "{:.1%}"),
    "deposit_balance_error": ("balance error", "{:.1e}"),
    # the spray budget (docs/budget.md)
    "budget_canopy_fraction": ("on canopy", "{:.0%}"),
    "budget_ground_off_field_fraction": ("ground off field", "{:.1%}"),
    "budget_evaporated_fraction": ("evaporated", "{:.1%}"),
    "budget_drift_5m_percent": ("drift at 5 m, %", "{:.2f}"),
}


#: operations figure -> (header, format)
OPERATIONS_COLUMNS: dict[str, tuple[str, str]] = {
    "sorties": ("sorties", "{:.0f}"),
    "job_time_s": ("job, s", "{:.0f}"),
    "idle_s": ("idle on the ground, s", "{:.0f}"),
    "battery_swaps": ("battery swaps", "{:.0f}"),
    "treated_area_ha": ("area, ha", "{:.3f}"),
    "field_capacity_ha_per_h": ("field capacity, ha/h", "{:.2f}"),
    "litres_per_ha": ("L/ha sprayed", "{:.1f}"),
    "energy_wh_per_ha": ("Wh/ha", "{:.0f}"),
}


def _fmt(v: Any, spec: str) -> str:
    return spec.format(v) if isinstance(v, (int, float)) and math.isfinite(v) else "-"


def deposition_markdown(runs: Sequence[Any], cell: Callable[[Any], str], max_rows: int = 50) -> list[str]:
    """Markdown lines of a "Spray deposition" table for the runs that sprayed (empty when none did)."""
    rows = [r for r in runs if isinstance((r.metrics() or {}).get("deposit_emitted_l"), (int, float))
            and r.metrics()["deposit_emitted_l"] > 0]
    if not rows:
        return []
    head = ["case", *(h for h, _ in DEPOSITION_COLUMNS.values())]
    lines = ["", "### Spray deposition", "", "| " + " | ".join(head) + " |",
             "|---|" + "---:|" * len(DEPOSITION_COLUMNS)]
    for r in rows[:max_rows]:
        m = r.metrics()
        lines.append("| " + " | ".join([cell(r.case), *(_fmt(m.get(k), f) for k, (_h, f) in DEPOSITION_COLUMNS.items())])
                     + " |")
    ops = [r for r in rows if r.summary.get("operations")]
    if ops:
        lines += ["", "### Spray operations", "", "| case | " + " | ".join(h for h, _ in OPERATIONS_COLUMNS.values())
                  + " |", "|---|" + "---:|" * len(OPERATIONS_COLUMNS)]
        for r in ops[:max_rows]:
            o = r.summary["operations"]
            lines.append("| " + " | ".join([cell(r.case), *(_fmt(o.get(k), f) for k, (_h, f) in
                                                           OPERATIONS_COLUMNS.items())]) + " |")
    return lines


def deposition_properties(run: Any) -> list[tuple[str, str]]:
    """(name, value) JUnit properties ``<case>:<metric>`` of a run's deposition metrics (none when it did not spray)."""
    m = run.metrics() or {}
    if not isinstance(m.get("deposit_emitted_l"), (int, float)):
        return []
    return [(f"{run.case}:{k}", repr(float(m[k]))) for k in DEPOSITION_COLUMNS if isinstance(m.get(k), (int, float))]
