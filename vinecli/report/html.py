"""``report.html``: one self-contained HTML overview (+ per-run pages for large batches).

Jinja2 renders ``templates/report.html.j2``; figures are embedded as base64 PNG data URIs,
CSS is inline, there are no scripts and no network references. Small batches (at most
``inline_limit`` runs) get every run's section in ``report.html``; larger ones get a paginated
overview (``report.html`` + ``pages/overview-N.html``, errored/failing runs first, a per-mission
summary) and one page per run in ``runs/<run id>.html``.
"""

from __future__ import annotations

import base64
import re
import statistics
from collections import Counter
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from vinecli.outputs import contained_path
from vinecli.report.baseline import Comparison
from vinecli.report.loader import Run
from vinecli.report.markdown import run_order
from vinecli.report.plots import FIGURES, check_spans
from vinecli.report.text import format_value, printable
from vinecli.report.vehicle_fit import vehicle_fit_text
from vinecli.runs.failsafes import describe_failsafe

TEMPLATE = "report.html.j2"


def _env() -> Any:
    import jinja2

    return jinja2.Environment(loader=jinja2.FileSystemLoader(str(Path(__file__).parent / "templates")),
                              autoescape=jinja2.select_autoescape(["html", "j2"]), trim_blocks=True,
                              lstrip_blocks=True, undefined=jinja2.StrictUndefined, finalize=_finalize)


def _finalize(value: Any) -> Any:
    """Every ``{{ }}`` output: plain strings lose their control characters (then autoescaping applies)."""
    from markupsafe import Markup

    if isinstance(value, str) and not isinstance(value, Markup):
        return printable(value)
    return value


def page_name(run: Run, taken: set[str]) -> str:
    """A safe, unique file stem for a run's page."""
    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", run.run_id).strip("._") or "run"
    name, k = stem, 2
    while name in taken:
        name, k = f"{stem}-{k}", k + 1
    taken.add(name)
    return name


def _result(run: Run, regressed: bool) -> str:
    return "error" if run.errored else "fail" if not run.passed else "regressed" if regressed else "pass"


def _secs(v: Any) -> str:
    try:
        return f"{float(v):.1f} s"
    except (TypeError, ValueError):
        return "-"


def _rtf(v: Any) -> str:
    try:
        return f"{float(v):.1f}×"
    except (TypeError, ValueError):
        return "-"


def _world(run: Run) -> str:
    w = run.summary.get("world")
    return str(w.get("name", "-")) if isinstance(w, dict) else str(w or "-")


def _section(run: Run, figs: Mapping[str, Mapping[str, Any]] | None, comparison: Comparison | None,
             figure_note: str, anchor: str) -> dict[str, Any]:
    s = run.summary
    regs = comparison.for_case(run.case) if comparison else []
    checks = [{
        "name": c.get("name"), "description": c.get("description") or "", "quantity": str(c.get("quantity", "")),
        "reduce": c.get("reduce") or "", "window": format_value(c.get("window")) if c.get("window") else "whole run / default",
        "value": format_value(c.get("value")), "op": c.get("op"), "bound": format_value(c.get("bound")), "passed": bool(c.get("passed")),
        "message": c.get("message") or "",
    } for c in run.checks]
    figures = []
    for fid, (caption, _fn) in FIGURES.items():
        f = (figs or {}).get(fid)
        if f is None:
            continue
        spans = ", ".join(c["name"] for c in check_spans(fid, run.checks))
        figures.append({"id": fid, "label": f"Figure {fid[3:]}", "caption": caption, "note": f.get("note", ""),
                        "b64": base64.b64encode(f["png"]).decode("ascii") if f.get("png") else None,
                        "spans": spans})
    metrics = sorted((k, format_value(v)) for k, v in run.metrics().items())
    return {
        "anchor": anchor, "case": run.case, "run_id": run.run_id, "mission": run.mission,
        "description": s.get("description") or "", "vehicle": s.get("vehicle", "-"), "world": _world(run),
        "vehicle_fit": vehicle_fit_text(s),
        "autopilot": s.get("autopilot", "-"), "seed": s.get("seed", "-"), "status": run.status,
        "status_message": s.get("status_message") or "", "sim_time": _secs(s.get("sim_time_s")),
        "wall_time": _secs(run.timing.get("wall_time_s")), "rtf": _rtf(run.timing.get("real_time_factor")),
        "error": run.error, "failsafes": [{"text": describe_failsafe(f), "detail": f.get("detail") or "",
                                           "position": format_value(f.get("position_enu"))} for f in run.failsafes],
        "result": _result(run, bool(regs)), "checks": checks, "n_passed": sum(c["passed"] for c in checks),
        "regressions": [{**g.to_dict(), "baseline": format_value(g.baseline), "current": format_value(g.current)} for g in regs],
        "metrics": metrics, "figures": figures, "figure_note": figure_note,
    }


def _missions(runs: Sequence[Run]) -> list[dict[str, Any]]:
    by: dict[str, list[Run]] = {}
    for r in runs:
        by.setdefault(r.mission, []).append(r)
    out = []
    for m, rs in sorted(by.items(), key=lambda kv: (-sum(not r.passed for r in kv[1]), kv[0])):
        sims = [float(r.summary.get("sim_time_s") or 0) for r in rs if not r.errored]
        rtfs = [float(r.timing.get("real_time_factor") or 0) for r in rs if not r.errored]
        top = Counter(c["name"] for r in rs for c in r.failed_checks).most_common(3)
        out.append({"mission": m, "n": len(rs), "passed": sum(r.passed for r in rs),
                    "failed": sum((not r.passed) and not r.errored for r in rs), "errors": sum(r.errored for r in rs),
                    "top_failed": ", ".join(f"{n} ×{k}" for n, k in top) or "-",
                    "sim_time": _secs(statistics.median(sims)) if sims else "-",
                    "rtf": _rtf(statistics.median(rtfs)) if rtfs else "-"})
    return out


# parameters: the runs and their figures, then keyword-only page options with their defaults
def write_html(out_dir: Path, runs: Sequence[Run], figures: Mapping[str, Mapping[str, Mapping[str, Any]]],
               comparison: Comparison | None = None, *, title: str = "vinecli report", runs_dir: str = "",
               pipeline: str | None = None, inline_limit: int = 20, page_size: int = 100,
               figure_notes: Mapping[str, str] | None = None, figure_policy: str = "",
               autopilots: Sequence[Mapping[str, Any]] = ()) -> Path:
    """Write ``report.html`` (and ``pages/``, ``runs/`` for large batches) into ``out_dir``; returns report.html.

    ``figures``: case -> fig id -> ``{"png", "note", "caption"}``; ``figure_notes``: case -> why it has no figures;
    ``autopilots``: comparisons of autopilots (:func:`vinecli.report.autopilots.html_blocks`), on the first page.
    """
    env = _env()
    tpl = env.get_template(TEMPLATE)
    notes = figure_notes or {}
    ordered = run_order(runs, comparison)
    reg_cases = {g.case for g in comparison.regressions} if comparison else set()
    inline = len(runs) <= inline_limit
    taken: set[str] = set()
    pages_of = {r.case: page_name(r, taken) for r in ordered}
    generated = datetime.now(UTC).isoformat(timespec="seconds")
    n_pages = 1 if inline else max(1, -(-len(ordered) // page_size))
    regs = comparison.regressions if comparison else []
    common = {
        "title": title, "runs_dir": runs_dir, "pipeline": pipeline, "generated": generated,
        "baseline_dir": comparison.baseline_dir if comparison else None,
        "totals": {"n": len(runs), "passed": sum(r.passed for r in runs),
                   "failed": sum((not r.passed) and not r.errored for r in runs),
                   "errors": sum(r.errored for r in runs), "failed_checks": sum(len(r.failed_checks) for r in runs),
                   "regressions": len(regs)},
    }
    if not inline:
        (out_dir / "runs").mkdir(exist_ok=True)
        for r in ordered:
            sec = _section(r, figures.get(r.case), comparison, notes.get(r.case, ""), pages_of[r.case])
            html = tpl.render(page="run", root="../", sections=[sec], **common)
            contained_path(out_dir, "runs", f"{pages_of[r.case]}.html").write_text(html, encoding="utf-8")
    if n_pages > 1:
        (out_dir / "pages").mkdir(exist_ok=True)
    report = out_dir / "report.html"
    for k in range(1, n_pages + 1):
        here = report if k == 1 else out_dir / "pages" / f"overview-{k}.html"
        root = "" if k == 1 else "../"
        chunk = ordered if inline else ordered[(k - 1) * page_size:k * page_size]
        rows = []
        for r in chunk:
            s = r.summary
            res = _result(r, r.case in reg_cases)
            rows.append({
                "case": r.case, "mission": r.mission, "vehicle": s.get("vehicle", "-"), "world": _world(r),
                "seed": s.get("seed", "-"), "status": r.status, "result": res,
                "result_text": {"pass": "pass", "fail": "FAIL", "error": "ERROR", "regressed": "regressed"}[res],
                "checks": f"{sum(bool(c.get('passed')) for c in r.checks)}/{len(r.checks)}",
                "duration": _secs(s.get("sim_time_s")), "rtf": _rtf(r.timing.get("real_time_factor")),
                "failed": ", ".join(c["name"] for c in r.failed_checks) or (r.error or "" if r.errored else ""),
                "href": f"#run-{pages_of[r.case]}" if inline else f"{root}runs/{pages_of[r.case]}.html",
            })
        pages = [{"num": j, "current": j == k,
                  "href": f"{root}report.html" if j == 1 else f"{root}pages/overview-{j}.html"} for j in
                 range(1, n_pages + 1)]
        sections = ([_section(r, figures.get(r.case), comparison, notes.get(r.case, ""), pages_of[r.case])
                     for r in ordered] if inline else [])
        html = tpl.render(page="overview", root=root, page_num=k, pages=pages, rows=rows, sections=sections,
                          missions=_missions(runs),
                          regressions=[{**g.to_dict(), "baseline": format_value(g.baseline), "current": format_value(g.current)}
                                       for g in regs[:200]],
                          regressions_more=max(0, len(regs) - 200), figure_policy=figure_policy,
                          autopilots=autopilots if k == 1 else [], **common)
        here.write_text(html, encoding="utf-8")
    return report
