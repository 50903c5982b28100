"""``vinecli run ...`` commands."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from vinecli.cli.console import handles_errors, out_console, progress, sim_progress
from vinecli.cli.options import (
    Px4AllowRemote,
    Px4ConnectTimeout,
    Px4Host,
    Px4Instance,
    Px4LockstepTimeout,
    Seed,
    ardupilot_bin_option,
    mcap_option,
    out_option,
    overwrite_option,
    px4_bin_option,
    workers_option,
    world_option,
)
from vinecli.sitl.options import PX4_DEFAULTS

if TYPE_CHECKING:
    from vinecli.batch.case import CaseResult
    from vinecli.batch.run import BatchResult

app = typer.Typer(help="Run missions (single or batch) in PyBullet.", no_args_is_help=True)


# parameters: Typer reads the command's options from its parameters, one per option
@app.command("mission")
@handles_errors
def mission_cmd(
    mission: Annotated[Path, typer.Argument(help="Mission YAML (pipelines/missions/*.yaml or any path).")],
    world: Annotated[Path, world_option("Built world directory (vinecli world build).")],
    out: Annotated[Path, out_option("Runs directory; the run goes to OUT/<run-id>/.")],
    seed: Seed = 0,
    autopilot: Annotated[str | None, typer.Option("--autopilot", help="builtin, px4 or ardupilot (default: the "
                                                  "mission's).")] = None,
    truth: Annotated[bool, typer.Option("--truth", help="Controllers use ground truth, not the estimator.")] = False,
    rate: Annotated[float | None, typer.Option("--rate", help="Recording rate, Hz (default: the mission's).")] = None,
    mcap: Annotated[bool, mcap_option("Also write run.mcap for Foxglove.")] = False,
    run_id: Annotated[str | None, typer.Option("--run-id", help="Run directory name (default <mission>-s<seed>).")] = None,
    px4_bin: Annotated[Path | None, px4_bin_option("PX4 SITL binary: vinecli starts PX4 for this run "
                                                   "(fresh process and working directory, free instance) and stops it.")] = None,
    ardupilot_bin: Annotated[Path | None, ardupilot_bin_option(
        "ArduCopter SITL binary: vinecli starts ArduPilot for this run (fresh process and working directory, "
        "free instance) and stops it.")] = None,
    px4_instance: Px4Instance = PX4_DEFAULTS.px4_instance,
    px4_host: Px4Host = PX4_DEFAULTS.px4_host,
    px4_connect_timeout: Px4ConnectTimeout = PX4_DEFAULTS.px4_connect_timeout_s,
    px4_lockstep_timeout: Px4LockstepTimeout = PX4_DEFAULTS.px4_step_timeout_s,
    px4_allow_remote: Px4AllowRemote = PX4_DEFAULTS.px4_allow_remote,
    mavlink: Annotated[str | None, typer.Option("--mavlink", help="Serve the built-in autopilot over MAVLink: "
                                                "udp:HOST:PORT / udpout: send to a GCS listening there (14540); "
                                                "udpin:HOST:PORT listen there; tcpin:HOST:PORT accept a TCP client; "
                                                "tcp:HOST:PORT connect to a TCP server.")] = PX4_DEFAULTS.mavlink,
    mavlink_port: Annotated[int | None, typer.Option("--mavlink-port", help="vinecli's own UDP port with udp:/udpout: "
                                                     "(default 14580; 0 = any free port).")] = PX4_DEFAULTS.mavlink_local_port,
    realtime: Annotated[bool, typer.Option("--realtime", help="With --mavlink: pace the run at wall-clock speed.")
                        ] = PX4_DEFAULTS.realtime,
    mavlink_allow_remote: Annotated[bool, typer.Option("--mavlink-allow-remote",
                                                       help="Allow a non-loopback --mavlink address.")
                                    ] = PX4_DEFAULTS.mavlink_allow_remote,
    overwrite: Annotated[bool, overwrite_option("Replace an existing OUT/<run-id>/.")] = False,
) -> None:
    """Run one mission and write OUT/<run-id>/ (time series, summary, events, manifest).

    Exit 1 if a check failed. Ctrl-C stops the run and keeps a partial run marked "interrupted".

    Example: vinecli run mission pipelines/missions/takeoff.yaml --world build/vineyard --out runs
    """
    from vinecli.errors import ChecksFailed, Interrupted, RuntimeFailure
    from vinecli.missions.spec_io import read_mission
    from vinecli.runs import RunRequest, run_mission
    from vinecli.sitl.options import AutopilotOptions, firmware_binary, px4_binary

    src = read_mission(mission)  # read once: run_mission takes it as it is
    spec = src.spec
    bar = sim_progress()
    with bar:
        task = bar.add_task(spec.name, total=spec.max_duration_s, info="")

        def on_progress(sim_t: float, wall_t: float) -> None:
            rtf = sim_t / wall_t if wall_t > 0 else 0.0
            bar.update(task, completed=min(sim_t, spec.max_duration_s), info=f"sim {sim_t:6.1f} s  {rtf:5.1f}x real time")

        options = AutopilotOptions(
            px4_instance=px4_instance, px4_bin=px4_binary(px4_bin), px4_step_timeout_s=px4_lockstep_timeout,
            mavlink_local_port=mavlink_port, px4_host=px4_host, px4_connect_timeout_s=px4_connect_timeout,
            mavlink=mavlink, realtime=realtime, mavlink_allow_remote=mavlink_allow_remote,
            px4_allow_remote=px4_allow_remote,
            ardupilot_bin=firmware_binary(ardupilot_bin, "--ardupilot-bin", "ArduPilot"))
        request = RunRequest(src, world, out, seed=seed, run_id=run_id, autopilot=autopilot, truth=truth or None,
                             record_rate=rate, mcap=mcap, overwrite=overwrite, autopilot_options=options)
        summary = run_mission(request, progress=on_progress)
    _checks_table(summary.checks, title=f"{summary.run_id}: {summary.status}")
    out_console.print(f"{summary.run_dir}  sim {summary.sim_time_s:.1f} s, wall {summary.wall_time_s:.1f} s, "
                      f"{summary.real_time_factor:.1f}x real time")
    if summary.status == "interrupted":
        raise Interrupted(f"{summary.status_message}; the partial run is in {summary.run_dir}",
                          signum=summary.stop_signal or 2)
    if summary.status == "error":
        raise RuntimeFailure(summary.status_message or "the run failed", path=summary.run_dir)
    if not summary.passed:
        raise ChecksFailed(f"{len(summary.failed_checks)} check(s) failed: "
                           + ", ".join(c["name"] for c in summary.failed_checks), path=summary.run_dir)


# parameters: Typer reads the command's options from its parameters, one per option
@app.command("batch")
@handles_errors
def batch_cmd(
    pipeline: Annotated[Path, typer.Argument(help="Pipeline YAML (pipelines/*.yaml).")],
    out: Annotated[Path, out_option("Runs directory (one run dir per case + batch.json).")],
    workers: Annotated[int, workers_option("Parallel cases.")] = 1,
    executor: Annotated[str, typer.Option("--executor", help="local (process pool) or dask.")] = "local",
    scheduler: Annotated[str | None, typer.Option("--scheduler", help="Dask scheduler address (default: local cluster).")] = None,
    resume: Annotated[bool, typer.Option("--resume", help="Skip cases whose run is already complete.")] = False,
    timeout: Annotated[float | None, typer.Option("--timeout", help="Wall-clock limit per case, s.")] = None,
    mcap: Annotated[bool, mcap_option("Also write run.mcap per case.")] = False,
    world: Annotated[Path | None, world_option("Built world dir or world spec replacing the pipeline's default world.")
                     ] = None,
    px4_bin: Annotated[Path | None, px4_bin_option("PX4 SITL binary: each PX4 case starts its own PX4 (one process "
                                                   "and instance per case, so --workers runs them in parallel).")] = None,
    ardupilot_bin: Annotated[Path | None, ardupilot_bin_option(
        "ArduCopter SITL binary: each ArduPilot case starts its own ArduPilot (one process and instance per "
        "case).")] = None,
) -> None:
    """Run every case of a pipeline (missions and sweeps) and write OUT/batch.json.

    Exit 1 if a check failed, 3 if a case could not run, 143/130 after SIGTERM/SIGINT (running cases are
    written as "interrupted" partial runs, the rest marked "interrupted" in batch.json; --resume finishes).

    Example: vinecli run batch pipelines/ci.yaml --out runs --workers 2
    """
    if executor == "local":  # the workers' fork server imports what a case needs while this process goes on
        from vinecli.batch.executors import start_fork_server

        start_fork_server()
    from vinecli.batch import run_batch
    from vinecli.batch.pipeline import pipeline_cases
    from vinecli.errors import ChecksFailed, Interrupted, RuntimeFailure

    n = len(pipeline_cases(pipeline, world))  # for the progress bar (and a bad pipeline fails before any work)
    bar = progress(transient=True)
    with bar:
        task = bar.add_task("cases", total=n, info="")

        def on_case(r: CaseResult, done: int, total: int) -> None:
            mark = "skipped" if r.skipped else ("ok" if r.passed else (r.error and "error") or "FAILED")
            bar.update(task, completed=done, info=f"{r.case}: {mark}")

        result = run_batch(pipeline, out, workers=workers, executor=executor, scheduler=scheduler, resume=resume,
                           timeout_s=timeout, progress=on_case, mcap=mcap, world=world, px4_bin=px4_bin,
                           ardupilot_bin=ardupilot_bin)
    _batch_table(result)
    stopped = f", {result.n_interrupted} interrupted" if result.n_interrupted else ""
    out_console.print(f"{result.runs_dir}/batch.json  {result.n_passed} passed, {result.n_failed} failed, "
                      f"{result.n_errors} errors{stopped} in {result.wall_time_s:.1f} s")
    if result.signum is not None:
        import signal

        raise Interrupted(f"stopped by {signal.Signals(result.signum).name}: {result.n_interrupted} case(s) "
                          "interrupted (run again with --resume)", path=result.runs_dir, signum=result.signum)
    if result.n_errors or result.n_interrupted:  # interrupted without a batch stop: a worker was stopped
        raise RuntimeFailure(f"{result.n_errors + result.n_interrupted} case(s) could not run to their end: "
                             + ", ".join(c.case for c in result.cases if c.error or c.status == "interrupted"),
                             path=result.runs_dir)
    if result.n_failed:
        raise ChecksFailed(f"{result.n_failed} case(s) failed checks: "
                           + ", ".join(c.case for c in result.cases if not c.passed), path=result.runs_dir)


@app.command("compare")
@handles_errors
def compare_cmd(
    mission: Annotated[Path, typer.Argument(help="Mission YAML flown by every autopilot.")],
    world: Annotated[Path, world_option("Built world dir or world spec.")],
    out: Annotated[Path, out_option("Runs directory (one run per autopilot + batch.json + comparison.json/png).")],
    seed: Seed = 0,
    autopilots: Annotated[str, typer.Option("--autopilots", help="Comma-separated autopilots to compare.")
                          ] = "builtin,px4,ardupilot",
    workers: Annotated[int, workers_option("Parallel runs.")] = 1,
    px4_bin: Annotated[Path | None, px4_bin_option("PX4 SITL binary (for px4).")] = None,
    ardupilot_bin: Annotated[Path | None, ardupilot_bin_option("ArduCopter SITL binary (for ardupilot).")] = None,
) -> None:
    """Fly one mission with several autopilots (same world and seed) and compare them side by side.

    Writes OUT/comparison.json and OUT/comparison.png; `vinecli report OUT` shows the comparison too.
    Exit 1 if a run failed a check, 3 if one could not run.

    Example: vinecli run compare pipelines/missions/px4/spray-rows.yaml --world build/vineyard --out cmp
    --px4-bin PX4/bin/px4 --ardupilot-bin ArduPilot/bin/arducopter
    """
    from vinecli.batch.compare_autopilots import compare_autopilots
    from vinecli.errors import ChecksFailed, RuntimeFailure
    from vinecli.report.autopilots import markdown_table

    names = [a.strip() for a in autopilots.split(",") if a.strip()]
    with progress(transient=True) as bar:
        task = bar.add_task("runs", total=len(names), info="")
        result, cmp = compare_autopilots(
            mission, world, out, autopilots=names, seed=seed, workers=workers, px4_bin=px4_bin, ardupilot_bin=ardupilot_bin,
            progress=lambda r, done, total: bar.update(task, completed=done, info=f"{r.case}: {r.status}"))
    _batch_table(result)
    if cmp is not None:
        out_console.print(markdown_table(cmp), markup=False)
        out_console.print(f"{out}/comparison.json, {out}/comparison.png")
    if result.n_errors:
        raise RuntimeFailure(f"{result.n_errors} run(s) could not run to their end: "
                             + ", ".join(c.case for c in result.cases if c.error), path=result.runs_dir)
    if result.n_failed:
        raise ChecksFailed(f"{result.n_failed} run(s) failed checks: "
                           + ", ".join(c.case for c in result.cases if not c.passed), path=result.runs_dir)


@app.command("checks")
@handles_errors
def checks_cmd(
    run_dir: Annotated[Path, typer.Argument(help="A run directory (RUNS/<run-id>/).")],
    mission: Annotated[Path | None, typer.Option("--mission", "-m", help="Evaluate this mission's checks instead "
                                                 "of the run's own mission.yaml.")] = None,
) -> None:
    """Evaluate checks again on a finished run (no simulation; the run directory is not changed).

    Exit 1 if a check fails. Example: vinecli run checks runs/gust-s0 --mission my-stricter-gust.yaml
    """
    from vinecli.errors import ChecksFailed
    from vinecli.runs import recheck_run

    summary, results = recheck_run(run_dir, mission)
    checks = [r.to_dict() for r in results]
    _checks_table(checks, title=f"{summary.get('run_id', run_dir.name)}: {summary.get('status')}")
    failed = [c["name"] for c in checks if not c["passed"]]
    if failed:
        raise ChecksFailed(f"{len(failed)} check(s) failed: {', '.join(failed)}", path=run_dir)


def _checks_table(checks: list[dict[str, Any]], title: str) -> None:
    from rich.markup import escape
    from rich.table import Table

    from vinecli.report.text import format_value

    t = Table(title=escape(title), title_justify="left")
    for col in ("check", "value", "op", "bound", "result"):
        t.add_column(col)
    for c in checks:  # names, values and messages come from the mission and the run: shown as text
        ok = "[green]pass[/]" if c["passed"] else "[red]FAIL[/]"
        t.add_row(escape(str(c["name"])), escape(format_value(c["value"])), escape(str(c["op"])),
                  escape(format_value(c["bound"])), ok)
    out_console.print(t)
    for c in checks:
        if not c["passed"]:
            out_console.print(f"  [red]{escape(str(c['name']))}[/]: {escape(str(c['message']))}", markup=True)


def _batch_table(result: BatchResult) -> None:
    from rich.markup import escape
    from rich.table import Table

    t = Table(title=escape(f"batch {result.pipeline}"), title_justify="left")
    for col in ("case", "status", "result", "sim s", "RTF", "failed checks / error"):
        t.add_column(col)
    for c in result.cases:
        res = "[yellow]error[/]" if c.error else ("[green]pass[/]" if c.passed else "[red]FAIL[/]")
        if c.skipped:
            res += " (resumed)"
        t.add_row(escape(c.case), escape(c.status), res, f"{c.sim_time_s:.1f}", f"{c.real_time_factor:.1f}",
                  escape(c.error or ", ".join(c.failed_checks)))
    out_console.print(t)
