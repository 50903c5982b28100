"""``vinecli terrain ...`` commands."""

from __future__ import annotations

import typer

app = typer.Typer(help="Turn DSMs and point clouds into simulator terrain.", no_args_is_help=True)
