"""Root Typer application: global flags and the command groups.

Groups: ``terrain``, ``world``, ``run``, ``plan``, ``px4``, ``vehicle``, ``gis``; ``report`` is a top-level
command. Library imports live inside command bodies so ``vinecli --help`` stays fast, and :func:`main` builds only
what the command line names: the group it runs (``vinecli run mission ...`` imports and builds the ``run``
commands alone), or, for the top-level help, each group's name and help without its commands (Typer reads every
command's signature when it builds one). ``app`` (``from vinecli.cli.app import app``) is the whole application.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from importlib import import_module
from typing import Annotated, Any

import typer

from vinecli import __version__

#: the command groups, in the order the help lists them (each ``vinecli.cli.<name>.app``)
GROUPS: tuple[str, ...] = ("terrain", "world", "run", "plan", "px4", "vehicle", "gis")
#: top-level commands (``vinecli.cli.<module>.app``'s commands at the root)
COMMANDS: dict[str, str] = {"report": "report"}
#: root options that end the command line before any group runs
_ROOT_EXITS = ("--help", "--version")


def _version(value: bool) -> None:
    if value:
        typer.echo(f"vinecli {__version__}")
        raise typer.Exit()


def root(
    verbose: Annotated[int, typer.Option("--verbose", "-v", count=True, help="More log output (-vv debug).")] = 0,
    debug: Annotated[bool, typer.Option("--debug", help="Show tracebacks instead of one-line errors.")] = False,
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")
    ] = False,
) -> None:
    """Global options."""
    from vinecli.cli.console import setup_logging

    setup_logging(verbose, debug)


def build_app(names: Sequence[str] | None = None, *, listing: bool = False) -> typer.Typer:
    """The application with the groups and top-level commands ``names`` (None: all of them). ``listing``: the
    groups with their name and help only (enough for the top-level help; their commands are not built)."""
    app = typer.Typer(
        name="vinecli",
        help="Simulation pipeline for vineyard spraying drones: terrain -> world -> missions -> report.",
        no_args_is_help=True,
        pretty_exceptions_enable=False,
        add_completion=False,
    )
    app.callback()(root)
    wanted = [*GROUPS, *COMMANDS] if names is None else names
    for name in GROUPS:
        if name in wanted:
            sub = import_module(f"vinecli.cli.{name}").app
            app.add_typer(typer.Typer(help=sub.info.help) if listing else sub, name=name)
    for name, module in COMMANDS.items():
        if name in wanted:
            app.add_typer(import_module(f"vinecli.cli.{module}").app)
    return app


def named(argv: Sequence[str]) -> str | None:
    """The group or top-level command a command line runs: its first word after the root options (none of which
    takes a value), or None (none, an unknown one, or ``--help``/``--version`` before it)."""
    for word in argv:
        if word in _ROOT_EXITS:
            return None
        if not word.startswith("-"):
            return word if word in GROUPS or word in COMMANDS else None
    return None


def __getattr__(name: str) -> Any:
    if name == "app":  # the whole application, built once on first use
        globals()["app"] = whole = build_app()
        return whole
    raise AttributeError(f"module 'vinecli.cli.app' has no attribute {name!r}")


def main() -> None:
    """Console-script entry point: SIGTERM stops a command like Ctrl-C (its temporary files removed, its locks
    released); the scratch folders, instance locks and output temporaries a killed vinecli left are removed
    (:func:`vinecli.scratch.sweep_scratch`, :func:`vinecli.outputs.sweep_gone_writers`); then it builds the group the
    command line names (or the listing of all of them) and runs the command, listing the folders it writes into for
    the next start should it be killed.

    Pydantic's plugins are off in the command's process unless the environment says otherwise: looking them up
    scans the metadata of every installed package before the first spec model is built, and vinecli has none."""
    from vinecli.outputs import sweep_gone_writers
    from vinecli.scratch import list_outputs, sweep_scratch
    from vinecli.stop_signals import abort_on_sigterm

    os.environ.setdefault("PYDANTIC_DISABLE_PLUGINS", "__all__")
    abort_on_sigterm()
    sweep_scratch()
    sweep_gone_writers()
    list_outputs()
    name = named(sys.argv[1:])
    build_app([name] if name is not None else None, listing=name is None)()
