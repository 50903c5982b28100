"""Root Typer application: global flags and the command groups.

Groups: ``terrain``, ``world``, ``run``, ``plan``, ``px4``, ``vehicle``, ``gis``; ``report`` is a top-level
command. Library imports live inside command bodies so ``vinecli --help`` stays fast.
"""

from __future__ import annotations

from typing import Annotated

import typer

from vinecli import __version__
from vinecli.cli import gis, plan, px4, report, run, terrain, vehicle, world
from vinecli.cli.console import setup_logging

app = typer.Typer(
    name="vinecli",
    help="Simulation pipeline for vineyard spraying drones: terrain -> world -> missions -> report.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
app.add_typer(terrain.app, name="terrain")
app.add_typer(world.app, name="world")
app.add_typer(run.app, name="run")
app.add_typer(plan.app, name="plan")
app.add_typer(px4.app, name="px4")
app.add_typer(vehicle.app, name="vehicle")
app.add_typer(gis.app, name="gis")
app.add_typer(report.app)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"vinecli {__version__}")
        raise typer.Exit()


@app.callback()
def root(
    verbose: Annotated[int, typer.Option("--verbose", "-v", count=True, help="More log output (-vv debug).")] = 0,
    debug: Annotated[bool, typer.Option("--debug", help="Show tracebacks instead of one-line errors.")] = False,
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")
    ] = False,
) -> None:
    """Global options."""
    setup_logging(verbose, debug)


def main() -> None:
    """Console-script entry point: SIGTERM stops a command like Ctrl-C (its temporary files removed, its locks
    released); the scratch folders, instance locks and output temporaries a killed vinecli left are removed
    (:func:`vinecli.scratch.sweep_scratch`, :func:`vinecli.outputs.sweep_gone_writers`); then the command runs, listing
    the folders it writes into for the next start should it be killed."""
    from vinecli.outputs import sweep_gone_writers
    from vinecli.scratch import list_outputs, sweep_scratch
    from vinecli.stop_signals import abort_on_sigterm

    abort_on_sigterm()
    sweep_scratch()
    sweep_gone_writers()
    list_outputs()
    app()
