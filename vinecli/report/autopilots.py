"""Autopilots side by side in the report: the runs of one mission and seed flown by different autopilots
(:func:`vinecli.runs.compare.compare_runs`), as a table (Markdown) and one figure ("figA").

The figure: ground tracks over the rows; tracking error, mission time and energy per autopilot; the dose
on each targeted row against the asked rate; the shares of the rows' planned length in hot spots and gaps.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.report.figure_base import DPI, png_bytes
from vinecli.report.text import format_value, md_text
from vinecli.runs import rundir
from vinecli.runs.compare import FIGURES, compare_runs

COLOURS = {"builtin": "#1f77b4", "px4": "#ff7f0e", "ardupilot": "#2ca02c"}


def comparison_groups(runs: Sequence[Any]) -> list[dict[str, Any]]:
    """Comparisons for the report's runs: per (mission, seed), the runs of two or more autopilots."""
    groups: dict[tuple[str, Any], dict[str, Path]] = {}
    for r in runs:
        if r.dir is None:
            continue
        s = r.summary
        groups.setdefault((str(s.get("mission")), s.get("seed")), {}).setdefault(str(s.get("autopilot")), r.dir)
    return [compare_runs(list(by_ap.values())) for by_ap in groups.values() if len(by_ap) >= 2]


def markdown_table(cmp: dict[str, Any]) -> str:
    """The comparison as a GitHub-flavoured Markdown table, one column per autopilot."""
    runs = cmp["runs"]
    head = "| | " + " | ".join(md_text(f"{r['autopilot']} ({r['firmware']})") for r in runs) + " |\n"
    head += "|---" * (len(runs) + 1) + "|\n"
    lines = ["| status | " + " | ".join(md_text(r["status"]) for r in runs) + " |"]
    for key, (label, unit) in FIGURES.items():
        lines.append(f"| {label} ({unit}) | " + " | ".join(format_value(r.get(key)) for r in runs) + " |")
    n_rows = max((len(r["rows"]) for r in runs), default=0)
    for i in range(n_rows):
        cells = []
        for r in runs:
            row = r["rows"][i] if i < len(r["rows"]) else {}
            cells.append(f"{format_value(row.get('mean_rate_lpha'))} L/ha ({_pct(row.get('rate_ratio'))}), "
                         f"{format_value(row.get('covered_fraction'))}")
        label = next((r["rows"][i].get("label") for r in runs if i < len(r["rows"])), None) or f"target {i}"
        lines.append(f"| {md_text(label)} dose (vs asked), covered | " + " | ".join(cells) + " |")
    lines.append("| dose checks | " + " | ".join({True: "pass", False: "FAIL", None: "-"}[r.get("dose_checks_passed")]
                                                 for r in runs) + " |")
    return f"### {md_text(cmp['mission'])}, seed {cmp['seed']}\n\n" + head + "\n".join(lines) + "\n"


def _pct(ratio: float | None) -> str:
    """A dose ratio as a signed percentage from the asked rate ('-' without one)."""
    return "-" if ratio is None else f"{100.0 * (ratio - 1.0):+.1f} %"


def markdown_section(comparisons: Sequence[dict[str, Any]]) -> str:
    """summary.md's "Autopilots side by side" section ('' without comparisons)."""
    if not comparisons:
        return ""
    return "\n## Autopilots side by side\n\n" + "\n".join(markdown_table(c) for c in comparisons)


def comparison_png(cmp: dict[str, Any]) -> bytes:
    """figA: tracks, tracking/time/energy, dose per row, hot spots and gaps (one colour per autopilot)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    runs = cmp["runs"]
    names = [str(r["autopilot"]) for r in runs]
    colours = [COLOURS.get(n, "#7f7f7f") for n in names]
    fig = Figure(figsize=(12.0, 8.0), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.subplots(2, 3, squeeze=False)
    fig.subplots_adjust(left=0.07, right=0.98, top=0.91, bottom=0.08, hspace=0.35, wspace=0.32)
    track = ax[0][0]
    rows_drawn = False
    for k, (r, c) in enumerate(zip(runs, colours, strict=True)):
        d = Path(r["dir"])
        ts = rundir.read_timeseries(d / rundir.TIMESERIES)  # widest first, dashed on top: overlapping tracks stay seen
        track.plot(ts["pos_enu_x_m"], ts["pos_enu_y_m"], color=c, lw=2.5 - 0.7 * k, ls=("-", "--", ":")[k % 3],
                   label=r["autopilot"])
        if not rows_drawn:
            for row in (rundir.read_summary(d).get("world") or {}).get("rows_enu") or []:
                p = np.asarray(row, dtype=float)
                track.plot(p[:, 0], p[:, 1], color="#999999", lw=3, alpha=0.4, zorder=0)
            rows_drawn = True
    track.set_title("ground tracks over the rows", fontsize=9)
    track.set_xlabel("east (m)")
    track.set_ylabel("north (m)")
    track.set_aspect("equal", adjustable="datalim")
    track.legend(fontsize=8)
    for a, key in zip((ax[0][1], ax[0][2], ax[1][0]), ("tracking_error_m", "mission_time_s", "energy_wh"), strict=True):
        vals = [r.get(key) for r in runs]
        a.bar(names, [v if v is not None else 0.0 for v in vals], color=colours)
        label, unit = FIGURES[key]
        a.set_title(f"{label} ({unit})", fontsize=9)
        for i, v in enumerate(vals):
            a.text(i, v or 0.0, format_value(v), ha="center", va="bottom", fontsize=8)
    _dose_panel(ax[1][1], runs, names, colours, cmp)
    _hot_gap_panel(ax[1][2], runs, names, cmp)
    fig.suptitle(f"Autopilots side by side — {cmp['mission']}, seed {cmp['seed']}", fontsize=11)
    return png_bytes(fig)


def _dose_panel(a: Any, runs: list[dict[str, Any]], names: list[str], colours: list[str], cmp: dict[str, Any]) -> None:
    n_rows = max((len(r["rows"]) for r in runs), default=0)
    if n_rows == 0:
        a.text(0.5, 0.5, "no spray deposition", ha="center", va="center", transform=a.transAxes)
        a.set_axis_off()
        return
    width = 0.8 / len(runs)
    for k, (r, c) in enumerate(zip(runs, colours, strict=True)):
        vals = [(row.get("mean_rate_lpha") or 0.0) for row in r["rows"]]
        a.bar(np.arange(len(vals)) + (k - (len(runs) - 1) / 2) * width, vals, width, color=c, label=names[k])
    nominal = next((r.get("nominal_rate_lpha") for r in runs if r.get("nominal_rate_lpha")), None)
    if nominal:
        a.axhline(nominal, color="k", ls="--", lw=1, label=f"asked {nominal:g} L/ha")
        tol = next((r["rate_tolerance"] for r in runs if r.get("rate_tolerance")), None)
        if tol:
            a.axhspan(nominal * (1 - tol), nominal * (1 + tol), color="k", alpha=0.08, label=f"±{tol:.0%} (dose check)")
    a.set_xticks(range(n_rows))
    longest = max(runs, key=lambda r: len(r["rows"]))["rows"]
    a.set_xticklabels([str(row.get("label") or row.get("row", i)) for i, row in enumerate(longest)])
    a.set_xlabel("targeted rows, as the mission lists them")
    a.set_title("mean dose per row (L/ha)", fontsize=9)
    a.legend(fontsize=7)


def _hot_gap_panel(a: Any, runs: list[dict[str, Any]], names: list[str], cmp: dict[str, Any]) -> None:
    x = np.arange(len(runs))
    hot = [r.get("hot_spot_fraction") or 0.0 for r in runs]
    gap = [r.get("gap_fraction") or 0.0 for r in runs]
    hf = next((r["hot_factor"] for r in runs if r.get("hot_factor")), cmp.get("hot_factor"))
    gf = next((r["gap_factor"] for r in runs if r.get("gap_factor")), cmp.get("gap_factor"))
    a.bar(x - 0.2, hot, 0.4, color="#d62728", label=f"hot spots (> {hf:g}x asked)")
    a.bar(x + 0.2, gap, 0.4, color="#9467bd", label=f"gaps (< {gf:g}x asked)")
    verdicts = [{True: "\ndose checks pass", False: "\ndose checks FAIL", None: ""}[r.get("dose_checks_passed")]
                for r in runs]
    a.set_xticks(x)
    a.set_xticklabels([n + v for n, v in zip(names, verdicts, strict=True)], fontsize=7)
    a.set_title("share of the rows' planned length (1 m windows)", fontsize=9)
    a.legend(fontsize=7)


def html_blocks(comparisons: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """What the HTML report shows of each comparison: header, rows of formatted values, the figure (base64)."""
    import base64

    out = []
    for cmp in comparisons:
        runs = cmp["runs"]
        rows = [["status", *[str(r["status"]) for r in runs]]]
        rows += [[f"{label} ({unit})", *[format_value(r.get(key)) for r in runs]] for key, (label, unit) in FIGURES.items()]
        out.append({"mission": cmp["mission"], "seed": cmp["seed"],
                    "head": [f"{r['autopilot']} ({r['firmware']})" for r in runs], "rows": rows,
                    "b64": base64.b64encode(comparison_png(cmp)).decode()})
    return out


__all__ = ["comparison_groups", "comparison_png", "html_blocks", "markdown_section", "markdown_table"]
