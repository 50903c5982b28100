"""Options several commands share (as rasterio's ``rio/options.py``): each flag's names are declared once here.

Factories (``out_option("...")``) for flags whose help depends on the command, ready-made ``Annotated`` types
for flags that mean the same everywhere. Defaults are never declared here: a command's signature takes them
from the library (:data:`vinecli.sitl.options.PX4_DEFAULTS`,
:data:`vinecli.spray_defaults.SPRAY_DEFAULTS`, :mod:`vinecli.terrain.defaults`). Only light modules
are imported so ``vinecli --help`` stays fast.
"""

from __future__ import annotations

from typing import Annotated, Any

import typer

from vinecli.constants import MAX_SEED


def out_option(help: str) -> Any:  # noqa: A002 - typer's name
    """``--out/-o``: where a command writes (a directory or file; the help says which)."""
    return typer.Option("--out", "-o", help=help, show_default=False)


def overwrite_option(help: str) -> Any:  # noqa: A002
    """``--overwrite``: replace an existing output."""
    return typer.Option("--overwrite", help=help)


def world_option(help: str) -> Any:  # noqa: A002
    """``--world/-w``: a built world directory (or, where the help says so, a world spec)."""
    return typer.Option("--world", "-w", help=help)


def workers_option(help: str) -> Any:  # noqa: A002
    """``--workers/-j``: how many processes work in parallel (``--jobs``, its older name, still accepted)."""
    return typer.Option("--workers", "-j", "--jobs", help=help)


def mcap_option(help: str) -> Any:  # noqa: A002
    """``--mcap``: also write run.mcap (Foxglove)."""
    return typer.Option("--mcap", help=help)


def px4_bin_option(help: str) -> Any:  # noqa: A002
    """``--px4-bin``: a PX4 SITL binary."""
    return typer.Option("--px4-bin", help=help)


def ardupilot_bin_option(help: str) -> Any:  # noqa: A002
    """``--ardupilot-bin``: an ArduCopter SITL binary."""
    return typer.Option("--ardupilot-bin", help=help)


#: ``--seed``: the run seed
Seed = Annotated[int, typer.Option("--seed", min=0, max=MAX_SEED, help="Run seed (sensor noise, turbulence).")]
#: ``--px4-instance``: PX4 SITL instance of a run
Px4Instance = Annotated[int | None, typer.Option(
    "--px4-instance", help="PX4 SITL instance (px4 -i N): TCP 4560+N (default 0, or a free one with --px4-bin).")]
#: ``--px4-host``: where vinecli listens for PX4
Px4Host = Annotated[str, typer.Option("--px4-host", help="Address to listen on for PX4 (loopback).")]
#: ``--px4-connect-timeout``
Px4ConnectTimeout = Annotated[float, typer.Option("--px4-connect-timeout", help="Seconds to wait for PX4.")]
#: ``--px4-lockstep-timeout``
Px4LockstepTimeout = Annotated[float | None, typer.Option(
    "--px4-lockstep-timeout",
    help="Seconds a physics step waits for PX4's actuator controls before it goes on without them (a stall, "
         "which fails the run). Default: wait for them (lockstep; a PX4 silent for 30 s is an error).")]
#: ``--px4-allow-remote``
Px4AllowRemote = Annotated[bool, typer.Option("--px4-allow-remote", help="Allow a non-loopback --px4-host.")]
