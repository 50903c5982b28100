"""``summary.md``: a short Markdown summary for ``$GITHUB_STEP_SUMMARY`` and pull requests.

Totals, one row per run (failing runs first, at most ``max_rows``), the failed checks with value
and bound, and the regressions against the baseline. Plain GitHub-flavoured Markdown tables.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from vinecli.report.baseline import Comparison
from vinecli.report.loader import Run
from vinecli.report.text import format_value, md_text
from vinecli.report.vehicle_fit import vehicle_fit_text


def _cell(v: Any) -> str:
    return md_text(v)


def run_order(runs: Sequence[Run], comparison: Comparison | None = None) -> list[Run]:
    """Errored runs first, then failed or regressed runs, then passing ones; by case name within each."""
    reg = {r.case for r in comparison.regressions} if comparison else set()

    def key(r: Run) -> tuple[int, str]:
        rank = 0 if r.errored else 1 if not r.passed else 2 if r.case in reg else 3
        return rank, r.case

    return sorted(runs, key=key)


def result_word(run: Run, regressed: bool = False) -> str:
    if run.errored:
        return "⚠️ error"
    if not run.passed:
        return "❌ failed"
    return "🔶 regressed" if regressed else "✅ passed"


def render_markdown(runs: Sequence[Run], comparison: Comparison | None = None, *, title: str = "vinecli report",
                    max_rows: int = 50, html_name: str | None = "report.html") -> str:
    """The Markdown text of ``summary.md``."""
    n = len(runs)
    n_err = sum(r.errored for r in runs)
    n_fail = sum((not r.passed) and not r.errored for r in runs)
    n_pass = n - n_err - n_fail
    regs = comparison.regressions if comparison else []
    reg_cases = {r.case for r in regs}
    ok = n_err == 0 and n_fail == 0 and not regs
    lines = [f"## {'✅' if ok else '❌'} {_cell(title)}: {n} run{'s' if n != 1 else ''} — {n_pass} passed, {n_fail} failed, "
             f"{n_err} error{'s' if n_err != 1 else ''}"
             + (f", {len(regs)} regression{'s' if len(regs) != 1 else ''} vs baseline" if comparison else ""), ""]
    lines += ["| case | mission | vehicle | seed | status | result | checks | sim time | RTF |",
              "|---|---|---|---:|---|---|---:|---:|---:|"]
    ordered = run_order(runs, comparison)
    for r in ordered[:max_rows]:
        s = r.summary
        n_ok = sum(bool(c.get("passed")) for c in r.checks)
        lines.append("| " + " | ".join(_cell(x) for x in (
            r.case, r.mission, s.get("vehicle", "-"), s.get("seed", "-"), r.status,
            result_word(r, r.case in reg_cases), f"{n_ok}/{len(r.checks)}",
            f"{float(s.get('sim_time_s') or 0):.1f} s", f"{float(r.timing.get('real_time_factor') or 0):.1f}×")) + " |")
    if n > max_rows:
        lines.append(f"\n… and {n - max_rows} more runs (all passing ones listed last); see the HTML report.")
    fitted = [(r, t) for r in ordered if (t := vehicle_fit_text(r.summary))]
    if fitted:
        lines += ["", "### Fitted vehicles", "", "| case | vehicle model |", "|---|---|"]
        lines += [f"| {_cell(r.case)} | {_cell(t)} |" for r, t in fitted[:max_rows]]
    safes = [r for r in ordered if r.failsafes]
    if safes:
        lines += ["", "### Failsafes", "", "| case | status | failsafe |", "|---|---|---|"]
        for r in safes[:max_rows]:
            lines.append(f"| {_cell(r.case)} | {_cell(r.status)} | {_cell(r.failsafe_text)} |")
    failed = [(r, c) for r in ordered for c in r.failed_checks]
    errors = [r for r in ordered if r.errored]
    if failed or errors:
        lines += ["", "### Failed checks", "", "| case | check | value | bound | detail |", "|---|---|---:|---|---|"]
        for r in errors:
            lines.append(f"| {_cell(r.case)} | (run) | - | - | error: {_cell(r.error)} |")
        for r, c in failed[:max_rows * 2]:
            lines.append("| " + " | ".join(_cell(x) for x in (
                r.case, c["name"], format_value(c.get("value")), f"{c.get('op')} {format_value(c.get('bound'))}",
                "; ".join(x for x in (c.get("message") or "", r.failsafe_text) if x))) + " |")
        if len(failed) > max_rows * 2:
            lines.append(f"\n… and {len(failed) - max_rows * 2} more failed checks.")
    from vinecli.report.deposition_tables import deposition_markdown

    lines += deposition_markdown(ordered, _cell, max_rows)
    if comparison is not None:
        lines += ["", f"### Regressions vs baseline {_cell(comparison.baseline_dir)}", ""]
        if regs:
            lines += ["| case | kind | name | detail |", "|---|---|---|---|"]
            for g in regs[:max_rows * 2]:
                lines.append(f"| {_cell(g.case)} | {g.kind} | {_cell(g.name)} | {_cell(g.message)} |")
        else:
            lines.append(f"No regressions ({comparison.compared} cases compared).")
        if comparison.missing_cases:
            lines.append("\nCases in the baseline but not in this batch: "
                         + ", ".join(_cell(c) for c in comparison.missing_cases[:20]))
    if html_name:
        lines += ["", f"Full report with figures: `{html_name}` (artifact)."]
    return "\n".join(lines) + "\n"
