"""``vinecli world ...`` commands."""

from __future__ import annotations

import typer

app = typer.Typer(help="Build simulator worlds from terrain, vehicles and wind.", no_args_is_help=True)
