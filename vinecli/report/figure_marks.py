"""What the run figures mark on their axes: event lines (lift-off, touchdown, tank empty, services), the
check windows of the quantities a figure shows (shaded green passed, red failed), a shared zero on twin
axes; and the guards that turn a run without the data into :class:`~vinecli.report.figure_base.NoData`."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from vinecli.report.figure_base import C_FAIL, C_OK, NoData, PlotData

__all__ = ["CHECK_TOPICS", "align_zero", "check_spans", "event_lines", "has_tank", "need", "shade_check_windows"]


def align_zero(ax: Any, tw: Any) -> None:
    """Make y = 0 sit at the same height on an axis and its twin (so signs can be compared)."""
    (a0, a1), (b0, b1) = ax.get_ylim(), tw.get_ylim()
    if not (a0 < 0 < a1 or b0 < 0 < b1):
        a0, b0 = min(a0, 0.0), min(b0, 0.0)
    # fraction of the axis below zero: use the larger of the two for both
    fa = -a0 / (a1 - a0) if a1 > a0 else 0.5
    fb = -b0 / (b1 - b0) if b1 > b0 else 0.5
    f = min(max(fa, fb, 0.05), 0.95)
    ax.set_ylim(-f / (1 - f) * max(a1, 1e-12) if a1 > 0 else a0, max(a1, 1e-12) if a1 > 0 else -a0 * (1 - f) / f)
    tw.set_ylim(-f / (1 - f) * max(b1, 1e-12) if b1 > 0 else b0, max(b1, 1e-12) if b1 > 0 else -b0 * (1 - f) / f)


def event_lines(ax: Any, data: PlotData, kinds: Sequence[str] = ("liftoff", "touchdown", "tank_empty")) -> None:
    styles = {"liftoff": ("#1f77b4", "lift-off"), "touchdown": ("#7f7f7f", "touchdown"),
              "tank_empty": ("#9467bd", "tank empty"), "battery_swap": ("#2e7d32", "battery swap"),
              "refill": ("#0d47a1", "refill / service")}
    every = ("battery_swap", "refill")  # one line per service of a refill job, labelled once
    lo = data.liftoff()
    drawn: list[float] = []
    for k in kinds:
        if k == "liftoff":
            times = [lo] if lo is not None else []
        else:
            times = data.event_times(k) if k in every else data.event_times(k)[-1:]
        times = [te for te in times if all(abs(te - d) > 0.05 for d in drawn)]  # a swap during a refill: once
        drawn += times
        for i, te in enumerate(times):
            color, label = styles[k]
            ax.axvline(te, color=color, ls=":", lw=1.2)
            if i == 0:
                ax.annotate(label, (te, 1.0), xycoords=("data", "axes fraction"), xytext=(2, -10),
                            textcoords="offset points", fontsize=7, color=color)


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


def shade_check_windows(axes: Sequence[Any], name: str, data: PlotData) -> None:
    """Shade each distinct check window once (red if any of its checks failed), labelled with the check names."""
    groups: dict[tuple[float, float], list[dict[str, Any]]] = {}
    for c in check_spans(name, data.summary.get("checks") or []):
        groups.setdefault((float(c["window"][0]), float(c["window"][1])), []).append(c)
    for i, ((t0, t1), cs) in enumerate(groups.items()):
        ok = all(c.get("passed") for c in cs)
        color = C_OK if ok else C_FAIL
        for j, ax in enumerate(axes):
            ax.axvspan(t0, t1, color=color, alpha=0.10, lw=0)
            if j == 0:
                label = ", ".join(f"{c['name']} ({'pass' if c.get('passed') else 'FAIL'})" for c in cs)
                label = label if len(label) <= 90 else label[:88] + "…"
                ax.annotate(f"checks: {label}", (t0, 0.0), xycoords=("data", "axes fraction"),
                            xytext=(3, 3 + 10 * i), textcoords="offset points", fontsize=7, color=color)


def need(data: PlotData, *names: str, what: str) -> None:
    missing = [n for n in names if not data.has(n)]
    if missing:
        raise NoData(f"no {what} in this run (no finite samples of {', '.join(missing)})")


def has_tank(data: PlotData) -> bool:
    return data.has("tank_mass_kg") and float(np.nanmax(data.cols["tank_mass_kg"])) > 0.0
