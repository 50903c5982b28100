"""``vinecli run ...`` commands."""

from __future__ import annotations

import typer

app = typer.Typer(help="Run missions (single or batch) in PyBullet.", no_args_is_help=True)
