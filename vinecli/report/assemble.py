"""``build_report``: runs directory -> report directory (HTML, Markdown, JUnit XML, JSON).

Everything is written through :func:`vinecli.outputs.atomic_output_dir` (nothing half-written).
Figures are rendered per run, in a process pool when several runs need them. For large batches
only a budget of runs gets figures (errored/failing/regressed runs first, then one run per
mission) so a 1,000-run report still builds in well under a minute; ``figures="all"`` renders
every run.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Literal, get_args

from vinecli.errors import InputError
from vinecli.outputs import Manifest, atomic_output_dir, check_output_target, write_json
from vinecli.report.autopilots import comparison_groups, html_blocks, markdown_section
from vinecli.report.baseline import Comparison, Regression, Tolerance, compare
from vinecli.report.loader import Run, compute_report_metrics, load_runs
from vinecli.runs.batch_json import BATCH_JSON, read_batch_json
from vinecli.runs.rundir import SUMMARY

log = logging.getLogger(__name__)

FORMATS = ("html", "md", "junit", "json")
FigurePolicy = Literal["auto", "all", "failed", "none"]
#: the figure policies, in the order the help lists them
FIGURE_POLICIES: tuple[str, ...] = get_args(FigurePolicy)
FILES = {"html": "report.html", "md": "summary.md", "junit": "junit.xml", "json": "summary.json"}


@dataclass
class ReportResult:
    """What ``build_report`` wrote and found. ``exit_code``: 1 if any check failed, a case errored or a
    regression was flagged, else 0."""

    out_dir: Path
    files: dict[str, Path] = field(default_factory=dict)
    n_runs: int = 0
    n_passed: int = 0
    n_failed: int = 0
    n_errors: int = 0
    failed_checks: list[tuple[str, str]] = field(default_factory=list)
    regressions: list[Regression] = field(default_factory=list)
    figure_runs: int = 0
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def html(self) -> Path | None:
        return self.files.get("html")

    @property
    def exit_code(self) -> int:
        return 1 if (self.n_failed or self.n_errors or self.regressions) else 0


def parse_formats(spec: str | Sequence[str]) -> tuple[str, ...]:
    """``"html,md"`` or a list -> validated tuple (InputError for unknown names)."""
    items = [s.strip().lower() for s in (spec.split(",") if isinstance(spec, str) else spec) if s.strip()]
    bad = [s for s in items if s not in FORMATS]
    if bad or not items:
        raise InputError(f"unknown --format {', '.join(bad) or '(empty)'} (choose from {', '.join(FORMATS)})")
    return tuple(dict.fromkeys(items))


def select_figure_runs(runs: Sequence[Run], policy: FigurePolicy, budget: int,
                       comparison: Comparison | None = None) -> list[Run]:
    """Runs that get figures: all (policy all, or auto with <= budget runs), failing/regressed first then one
    per mission up to ``budget`` (auto), only failing/regressed (failed, capped at budget), none."""
    drawable = [r for r in runs if r.dir is not None]
    if policy == "none":
        return []
    if policy == "all" or (policy == "auto" and len(drawable) <= budget):
        return drawable
    reg = {g.case for g in comparison.regressions} if comparison else set()
    bad = [r for r in drawable if not r.passed or r.case in reg]
    chosen = bad[:budget]
    if policy == "auto":
        have = {r.mission for r in chosen}
        for r in drawable:
            if len(chosen) >= budget:
                break
            if r.mission not in have:
                chosen.append(r)
                have.add(r.mission)
    return chosen


def _render_one(run_dir: str) -> tuple[str, dict[str, dict[str, Any]]]:
    os.environ.setdefault("MPLBACKEND", "Agg")
    from vinecli.report.plots import render_figures

    return run_dir, render_figures(run_dir)


def render_all(runs: Sequence[Run], workers: int = 1, progress: Callable[[int, int], None] | None = None
               ) -> dict[str, dict[str, dict[str, Any]]]:
    """Figures of ``runs`` (case -> fig id -> {png, note, caption}); a spawn process pool when workers > 1."""
    by_dir = {str(r.dir): r.case for r in runs if r.dir is not None}
    out: dict[str, dict[str, dict[str, Any]]] = {}
    total = len(by_dir)
    if total == 0:
        return out
    if workers <= 1 or total == 1:
        for i, d in enumerate(by_dir, 1):
            out[by_dir[d]] = _render_one(d)[1]
            if progress:
                progress(i, total)
        return out
    import multiprocessing as mp

    with ProcessPoolExecutor(max_workers=min(workers, total), mp_context=mp.get_context("spawn")) as ex:
        futs = [ex.submit(_render_one, d) for d in by_dir]
        for i, fut in enumerate(as_completed(futs), 1):
            d, figs = fut.result()
            out[by_dir[d]] = figs
            if progress:
                progress(i, total)
    return out


def summary_dict(runs: Sequence[Run], comparison: Comparison | None, runs_dir: Path,
                 figures: Mapping[str, Mapping[str, Any]], pages: Mapping[str, str],
                 autopilots: Sequence[Mapping[str, Any]] = ()) -> dict[str, Any]:
    """The report's machine-readable ``summary.json`` (``autopilots``: :func:`comparison_groups`)."""
    from vinecli import __version__

    regs = comparison.regressions if comparison else []
    n_err = sum(r.errored for r in runs)
    n_fail = sum((not r.passed) and not r.errored for r in runs)
    return {
        "tool": "vinecli report", "version": __version__,
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"), "runs_dir": str(runs_dir),
        "passed": n_err == 0 and n_fail == 0 and not regs,
        "exit_code": 1 if (n_err or n_fail or regs) else 0,
        "totals": {"runs": len(runs), "passed": len(runs) - n_err - n_fail, "failed": n_fail, "errors": n_err,
                   "checks": sum(len(r.checks) for r in runs),
                   "failed_checks": sum(len(r.failed_checks) for r in runs), "regressions": len(regs)},
        "runs": [{
            "case": r.case, "run_id": r.run_id, "mission": r.mission, "vehicle": r.summary.get("vehicle"),
            "world": (r.summary.get("world") or {}).get("name") if isinstance(r.summary.get("world"), dict)
            else r.summary.get("world"),
            "seed": r.summary.get("seed"), "status": r.status, "status_message": r.summary.get("status_message"),
            "passed": r.passed, "error": r.error, "sim_time_s": r.summary.get("sim_time_s"),
            "failsafes": r.failsafes, "timing": r.timing,
            "checks": r.checks, "failed_checks": [c["name"] for c in r.failed_checks], "metrics": r.metrics(),
            "regressions": [g.to_dict() for g in (comparison.for_case(r.case) if comparison else [])],
            "figures": {fid: ("rendered" if f.get("png") else f"skipped: {f.get('note')}")
                        for fid, f in (figures.get(r.case) or {}).items()},
            "page": pages.get(r.case),
        } for r in runs],
        "regressions": [g.to_dict() for g in regs],
        "baseline": comparison.to_dict() if comparison else None,
        "autopilots": list(autopilots),
    }


def _pipeline_name(runs_dir: Path) -> str | None:
    """The pipeline a batch's runs directory comes from (its batch.json), None for loose runs."""
    if not (runs_dir / BATCH_JSON).is_file():
        return None
    try:
        return read_batch_json(runs_dir / BATCH_JSON).get("pipeline")
    except InputError:
        return None


def _figure_notes(runs: Sequence[Any], chosen: Sequence[Any], want_figs: bool, figures: str,
                  max_figure_runs: int) -> tuple[dict[str, str], str]:
    """(per-case note of why a run has no figures, the figure policy's note for the report; "" when every run
    has them)."""
    chosen_cases = {r.case for r in chosen}
    notes = {}
    policy_note = ""
    if want_figs and len(chosen) < sum(r.dir is not None for r in runs):
        policy_note = (f"Figures rendered for {len(chosen)} of {len(runs)} runs (policy '{figures}', budget "
                       f"{max_figure_runs}: errored/failing/regressed runs first, then one run per mission). "
                       f"Use --figures all to render every run.")
        for r in runs:
            if r.case not in chosen_cases:
                notes[r.case] = ("figures not rendered for this run: " + policy_note) if r.dir is not None else \
                    "no figures: the case did not produce a run directory"
    for r in runs:
        if r.dir is None:
            notes[r.case] = "no figures: the case did not produce a run directory"
    return notes, policy_note


# parameters: keyword-only options, each with its default, one per `vinecli report` option; a caller names the ones it sets
def build_report(
    runs_dir: str | Path,
    out_dir: str | Path,
    formats: str | Sequence[str] = FORMATS,
    baseline: str | Path | None = None,
    *,
    tolerances: Mapping[str, Tolerance] | None = None,
    figures: FigurePolicy = "auto",
    max_figure_runs: int = 20,
    inline_limit: int = 20,
    page_size: int = 100,
    workers: int | None = None,
    title: str | None = None,
    overwrite: bool = False,
    progress: Callable[[str, int, int], None] | None = None,
) -> ReportResult:
    """Build the report of ``runs_dir`` into ``out_dir`` (atomically) and return a :class:`ReportResult`.

    ``formats``: any of html, md, junit, json; ``baseline``: an earlier runs directory to compare with by case
    name (regressions per :mod:`vinecli.report.baseline`, ``tolerances`` override the defaults);
    ``figures``/``max_figure_runs``: which runs get figures (see :func:`select_figure_runs`); ``inline_limit``:
    batches up to this size put every run in report.html, larger ones get runs/<id>.html pages and an overview
    paginated by ``page_size``; ``workers``: figure processes (default min(4, CPUs)).
    Raises InputError (exit 2) for a bad runs/baseline directory or option, OutputError (exit 2, before any
    work) when ``out_dir`` is not writable or exists without ``overwrite``, and before anything is written when it
    is, contains or lies inside a run folder it reads (a report may go into the runs folder itself).
    """
    fmts = parse_formats(formats)
    if figures not in FIGURE_POLICIES:
        raise InputError(f"unknown figures policy {figures!r} ({', '.join(FIGURE_POLICIES)})")
    if max_figure_runs < 0 or inline_limit < 0 or page_size < 1:
        raise InputError("max_figure_runs and inline_limit must be >= 0, page_size >= 1")
    runs_dir = Path(runs_dir)
    tops = [d / name for d in (runs_dir, *([Path(baseline)] if baseline is not None else [])) for name in (BATCH_JSON, SUMMARY)]
    check_output_target(Path(out_dir), overwrite=overwrite, inputs=tops, kind="report")  # before reading the runs
    workers = workers if workers is not None else max(1, min(4, os.cpu_count() or 1))
    manifest = Manifest(command="report", parameters={
        "runs_dir": str(runs_dir), "formats": list(fmts), "baseline": str(baseline) if baseline else None,
        "figures": figures, "max_figure_runs": max_figure_runs, "inline_limit": inline_limit,
        "page_size": page_size, "workers": workers,
        "tolerances": {k: vars(v) for k, v in (tolerances or {}).items()}})
    t0 = time.perf_counter()
    with manifest.stage("load"):
        runs = load_runs(runs_dir)
        for r in runs:
            r.report_metrics = compute_report_metrics(r)
    manifest.inputs = [r.dir / SUMMARY for r in runs if r.dir is not None]
    autopilots = comparison_groups(runs)  # runs of one mission and seed by several autopilots
    comparison = None
    if baseline is not None:
        with manifest.stage("baseline"):
            base_runs = load_runs(baseline)
            for r in base_runs:
                r.report_metrics = compute_report_metrics(r)
            comparison = compare(runs, base_runs, str(baseline), tolerances)
    # the inputs are the run folders read (and batch.json): the report may go into the runs folder, not
    # over or into a run, nor contain one
    read = [r.dir for r in [*runs, *(base_runs if baseline is not None else [])] if r.dir is not None]
    check_output_target(Path(out_dir), overwrite=overwrite, inputs=[*read, runs_dir / BATCH_JSON], kind="report")
    pipeline = _pipeline_name(runs_dir)
    want_figs = "html" in fmts
    chosen = select_figure_runs(runs, figures, max_figure_runs, comparison) if want_figs else []
    figs: dict[str, dict[str, dict[str, Any]]] = {}
    with manifest.stage("figures"):
        if chosen:
            figs = render_all(chosen, workers, (lambda i, n: progress("figures", i, n)) if progress else None)
    notes, policy_note = _figure_notes(runs, chosen, want_figs, figures, max_figure_runs)
    ttl = title or (f"vinecli report — {pipeline}" if pipeline else "vinecli report")
    result = ReportResult(out_dir=Path(out_dir), n_runs=len(runs), n_errors=sum(r.errored for r in runs),
                          n_failed=sum((not r.passed) and not r.errored for r in runs),
                          failed_checks=[(r.case, c["name"]) for r in runs for c in r.failed_checks],
                          regressions=list(comparison.regressions) if comparison else [], figure_runs=len(chosen))
    result.n_passed = result.n_runs - result.n_failed - result.n_errors
    inline = len(runs) <= inline_limit
    with atomic_output_dir(Path(out_dir), manifest, overwrite=overwrite) as tmp:
        pages: dict[str, str] = {}
        if "html" in fmts:
            from vinecli.report.html import page_name, write_html

            with manifest.stage("html"):
                write_html(tmp, runs, figs, comparison, title=ttl, runs_dir=str(runs_dir), pipeline=pipeline,
                           inline_limit=inline_limit, page_size=page_size, figure_notes=notes,
                           figure_policy=policy_note, autopilots=html_blocks(autopilots))
            if not inline:
                from vinecli.report.markdown import run_order

                taken: set[str] = set()
                pages = {r.case: f"runs/{page_name(r, taken)}.html" for r in run_order(runs, comparison)}
            else:
                pages = {r.case: "report.html" for r in runs}
        if "md" in fmts:
            from vinecli.report.markdown import render_markdown

            with manifest.stage("markdown"):
                (tmp / FILES["md"]).write_text(render_markdown(runs, comparison, title=ttl,
                                                               html_name=FILES["html"] if "html" in fmts else None)
                                               + markdown_section(autopilots), encoding="utf-8")
        if "junit" in fmts:
            from vinecli.report.junit import write_junit

            with manifest.stage("junit"):
                write_junit(tmp / FILES["junit"], runs, comparison, name=ttl)
        if "json" in fmts:
            with manifest.stage("json"):
                write_json(tmp / FILES["json"], summary_dict(runs, comparison, runs_dir, figs, pages, autopilots))
        manifest.extra = {"exit_code": result.exit_code, "runs": len(runs), "figure_runs": len(chosen)}
    result.files = {f: Path(out_dir) / FILES[f] for f in fmts}
    result.timings = dict(manifest.timings)
    result.timings["total"] = round(time.perf_counter() - t0, 4)
    log.info("report of %d runs in %s (%.2f s)", len(runs), out_dir, result.timings["total"])
    return result
