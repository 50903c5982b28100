"""``vinecli report`` command."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from vinecli.cli.console import handles_errors, out_console, progress
from vinecli.cli.options import out_option, overwrite_option, workers_option

app = typer.Typer()


# parameters: Typer reads the command's options from its parameters, one per option
@app.command("report")
@handles_errors
def report_cmd(
    runs: Annotated[Path, typer.Argument(help="Runs directory (vinecli run batch --out RUNS) or one run directory.")],
    out: Annotated[Path, out_option("Report directory (report.html, summary.md, junit.xml, summary.json).")],
    baseline: Annotated[Path | None, typer.Option("--baseline", help="Earlier runs directory to compare with "
                                                                     "(same case names).")] = None,
    fmt: Annotated[str, typer.Option("--format", help="Comma-separated: html, md, junit, json.")] = "html,md,junit,json",
    tolerance: Annotated[list[str] | None, typer.Option(
        "--tolerance", help="Baseline tolerance NAME=ABS or NAME=ABS:REL (repeatable), e.g. hpos_error_max_m=0.1.")
    ] = None,
    figures: Annotated[str, typer.Option("--figures", help="Which runs get figures: auto (all for small batches; "
                                                           "failing first up to --max-figure-runs), all, failed, "
                                                           "none.")] = "auto",
    max_figure_runs: Annotated[int, typer.Option("--max-figure-runs", help="Figure budget (runs) for "
                                                                           "--figures auto/failed.")] = 20,
    workers: Annotated[int | None, workers_option("Processes rendering figures (default: min(4, CPUs)).")] = None,
    overwrite: Annotated[bool, overwrite_option("Replace an existing, non-empty --out.")] = False,
) -> None:
    """Build the HTML/Markdown/JUnit/JSON report of a batch of runs (thesis figures 16-21 per run).

    Exit 1 if a check failed, a case errored or a regression against --baseline was flagged; 2 for bad input.

    Example: vinecli report runs --out report --baseline runs-main
    """
    from vinecli.errors import ChecksFailed, InputError
    from vinecli.report import build_report
    from vinecli.report.assemble import FIGURE_POLICIES
    from vinecli.report.baseline import parse_tolerances

    if figures not in FIGURE_POLICIES:
        raise InputError(f"unknown --figures {figures!r} ({', '.join(FIGURE_POLICIES)})")
    bar = progress()
    with bar:
        task = bar.add_task("figures", total=None, info="")

        def on_progress(stage: str, done: int, total: int) -> None:
            bar.update(task, completed=done, total=total, info=stage)

        result = build_report(runs, out, fmt, baseline, tolerances=parse_tolerances(tolerance or []),
                              figures=figures, max_figure_runs=max_figure_runs, workers=workers, overwrite=overwrite,
                              progress=on_progress)  # type: ignore[arg-type]
    out_console.print(f"{result.n_runs} runs: {result.n_passed} passed, {result.n_failed} failed, "
                      f"{result.n_errors} errors" + (f", {len(result.regressions)} regressions vs {baseline}"
                                                     if baseline is not None else "")
                      + f" ({result.timings.get('total', 0.0):.1f} s)")
    for name, path in result.files.items():
        out_console.print(f"  {name:5s} {path}")
    if result.html is not None:
        out_console.print(f"report: {result.html.resolve()}")
    if result.exit_code:
        parts = []
        if result.failed_checks:
            parts.append(f"{len(result.failed_checks)} check(s) failed")
        if result.n_errors:
            parts.append(f"{result.n_errors} case(s) errored")
        if result.regressions:
            parts.append(f"{len(result.regressions)} regression(s)")
        raise ChecksFailed(", ".join(parts) or "runs failed", path=result.html or result.out_dir)
