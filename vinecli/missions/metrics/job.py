"""Whole-field refill job metrics: sorties, job time, rows sprayed, area rate, litres per
sortie; and the deposition metrics the model reports (docs/deposition.md)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vinecli.missions.metrics.base import METRICS, Metric, Window, event_time_or_none, metric, nan
from vinecli.missions.rundata import RunData


def _job_span(data: RunData) -> tuple[float, float] | None:
    """(first lift-off, last armed sample) in s, or None without a lift-off."""
    t0 = event_time_or_none(data, "liftoff")
    if t0 is None or not data.has("armed"):
        return None
    armed = np.flatnonzero(data.column("armed") > 0.5)
    return (t0, float(data.t[armed[-1]])) if armed.size else None


def _rows_sprayed(data: RunData) -> tuple[float, float]:
    """(fraction, length m) of the context's rows that liquid was delivered over; computed once per RunData
    (a KD-tree over the spraying samples) for the metrics that need it."""
    from vinecli.missions.job import rows_sprayed

    cached = data.cache.get("rows_sprayed")
    if cached is None:
        cached = data.cache["rows_sprayed"] = rows_sprayed(data.timeseries, getattr(data.context, "rows_enu", ()) or ())
    return cached


@metric("sorties", "1")
def sorties(data: RunData, window: Window) -> float:
    """Number of sorties flown (take-offs of a refill job; 1 for a single flight), from the sortie column."""
    if not data.has("sortie"):
        return nan()
    s = data.column("sortie")
    return float(np.nanmax(s)) if np.isfinite(s).any() else nan()


@metric("job_time_s", "s")
def job_time_s(data: RunData, window: Window) -> float:
    """First lift-off to the last disarm of the run (ground service between sorties included), s."""
    span = _job_span(data)
    return span[1] - span[0] if span is not None else nan()


@metric("rows_sprayed_fraction", "1")
def rows_sprayed_fraction(data: RunData, window: Window) -> float:
    """Share of the target rows' length that liquid was delivered over (within 0.5 m); NaN if nothing was sprayed."""
    if not data.has("tank_flow_lps") or not (np.nan_to_num(data.column("tank_flow_lps")) > 0).any():
        return nan()
    return _rows_sprayed(data)[0]


@metric("area_rate_ha_per_h", "ha/h")
def area_rate_ha_per_h(data: RunData, window: Window) -> float:
    """Sprayed area (sprayed row length x row spacing) per hour of job time, ha/h."""
    from vinecli.rows.detect import row_spacing_m

    t_job = job_time_s(data, None)
    if not data.has("tank_flow_lps") or not t_job > 0:
        return nan()
    length = _rows_sprayed(data)[1]
    return length * row_spacing_m(getattr(data.context, "rows_enu", ()) or ()) / 1e4 / (t_job / 3600.0)


@metric("litres_per_sortie", "L")
def litres_per_sortie(data: RunData, window: Window) -> float:
    """Liquid delivered (integral of tank_flow_lps) per sortie, L."""
    n = sorties(data, None)
    if not data.has("tank_flow_lps") or not n > 0:
        return nan()
    from vinecli.missions.job import integral

    return integral(data.timeseries, "tank_flow_lps") / n if data.t.size > 1 else nan()



# ---------------------------------------------------------------- spray deposition (docs/deposition.md)
def _reported(name: str) -> Callable[[RunData, Window], float]:
    def fn(data: RunData, window: Window) -> float:
        v = data.metrics.get(name)
        return float(v) if isinstance(v, (int, float)) else nan()

    return fn


def _register_deposition() -> None:
    """The deposition metrics are computed once per run by the model (whole run; the window is ignored)."""
    from vinecli.missions.as_applied import AS_APPLIED_METRICS
    from vinecli.missions.budget_metrics import BUDGET_METRICS
    from vinecli.missions.deposition_metrics import DEPOSIT_METRICS

    for name, (unit, doc) in {**DEPOSIT_METRICS, **BUDGET_METRICS, **AS_APPLIED_METRICS}.items():
        METRICS[name] = Metric(_reported(name), unit, f"{doc} (whole run; window ignored)")


_register_deposition()
