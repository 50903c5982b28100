"""What the time-series figures mark: event lines (lift-off, touchdown, tank empty, services) and the check windows
of the quantities a figure shows (shaded green passed, red failed); and the guards that turn a run without the
data into :class:`~vinecli.report.figure_base.NoData`."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from vinecli.report.figure_base import NoData, PlotData

__all__ = ["CHECK_TOPICS", "EVENT_STYLES", "check_spans", "check_windows", "event_marks", "has_tank", "need"]


EVENT_STYLES = {"liftoff": ("#1f77b4", "lift-off"), "touchdown": ("#7f7f7f", "touchdown"),
                "tank_empty": ("#9467bd", "tank empty"), "battery_swap": ("#2e7d32", "battery swap"),
                "refill": ("#0d47a1", "refill / service")}


def event_marks(data: PlotData, kinds: Sequence[str] = ("liftoff", "touchdown", "tank_empty")
                ) -> list[tuple[float, str, str]]:
    """(t s, label, colour) of the events of ``kinds`` a figure marks with a dotted line: the main lift-off, the last
    touchdown and tank-empty, every service of a refill job (a swap during a refill once; each kind labelled once)."""
    every = ("battery_swap", "refill")
    lo = data.liftoff()
    out: list[tuple[float, str, str]] = []
    for k in kinds:
        if k == "liftoff":
            times = [lo] if lo is not None else []
        else:
            times = data.event_times(k) if k in every else data.event_times(k)[-1:]
        color, label = EVENT_STYLES[k]
        times = [te for te in times if all(abs(te - d[0]) > 0.05 for d in out)]
        out += [(te, label if i == 0 else "", color) for i, te in enumerate(times)]  # labelled once
    return out


#: check quantities each figure shows (substring match on the check's quantity)
CHECK_TOPICS: dict[str, tuple[str, ...]] = {
    "fig17": ("tank_force", "liftoff_force", "climb_tank", "climb_duration", "liquid_weight"),
    "fig18": ("drag",),
    "fig19": ("tank_level", "tank_flow", "drain", "tank_mass"),
    "fig20": ("rotor", "hover", "mass"),
    "fig21": ("tilt", "wind", "hpos", "roll", "pitch", "yaw"),
    "fig22": ("battery", "energy", "sortie", "soc"),
}


def check_spans(name: str, checks: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Checks with a time window whose quantity belongs to figure ``name``."""
    topics = CHECK_TOPICS.get(name, ())
    out = []
    for c in checks:
        w = c.get("window")
        if isinstance(w, (list, tuple)) and len(w) == 2 and any(k in str(c.get("quantity", "")) for k in topics):
            out.append(c)
    return out


def check_windows(name: str, data: PlotData) -> list[tuple[float, float, bool, str]]:
    """Each distinct window of the checks figure ``name`` shows, once: (t0 s, t1 s, passed (all of its checks),
    "checks: name (pass), ..." )."""
    groups: dict[tuple[float, float], list[dict[str, Any]]] = {}
    for c in check_spans(name, data.summary.get("checks") or []):
        groups.setdefault((float(c["window"][0]), float(c["window"][1])), []).append(c)
    out = []
    for (t0, t1), cs in groups.items():
        label = ", ".join(f"{c['name']} ({'pass' if c.get('passed') else 'FAIL'})" for c in cs)
        out.append((t0, t1, all(bool(c.get("passed")) for c in cs), "checks: " + label))
    return out


def need(data: PlotData, *names: str, what: str) -> None:
    missing = [n for n in names if not data.has(n)]
    if missing:
        raise NoData(f"no {what} in this run (no finite samples of {', '.join(missing)})")


def has_tank(data: PlotData) -> bool:
    return data.has("tank_mass_kg") and float(np.nanmax(data.cols["tank_mass_kg"])) > 0.0
