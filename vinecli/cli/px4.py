"""``vinecli px4 ...`` commands."""

from __future__ import annotations

import typer

app = typer.Typer(help="PX4 SITL helpers.", no_args_is_help=True)
