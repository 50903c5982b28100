"""``vinecli px4 ...`` commands."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from vinecli.cli.console import handles_errors, out_console
from vinecli.cli.options import px4_bin_option
from vinecli.sitl.options import PX4_DEFAULT_INSTANCE, PX4_DEFAULTS, PX4_PROBE_TIMEOUT_S

app = typer.Typer(help="PX4 SITL helpers.", no_args_is_help=True)


@app.command("doctor")
@handles_errors
def doctor_cmd(
    px4_bin: Annotated[Path | None, px4_bin_option("PX4 SITL binary (build/px4_sitl_default/bin/px4).")] = None,
    instance: Annotated[int, typer.Option("--instance", "-i", help="PX4 instance (px4 -i N): ports 4560+N, 14540+N, 14580+N.")
                        ] = PX4_DEFAULT_INSTANCE,
    host: Annotated[str, typer.Option("--host", help="Address vinecli listens on / PX4 runs at.")] = PX4_DEFAULTS.px4_host,
    timeout: Annotated[float, typer.Option("--timeout", help="Seconds to wait for a running PX4 to answer.")
                       ] = PX4_PROBE_TIMEOUT_S,
) -> None:
    """Check that PX4 SITL and vinecli can reach each other; print the command that starts PX4.

    Exit 1 when a check fails (binary missing, simulator port taken).

    Example: vinecli px4 doctor --px4-bin ~/PX4-Autopilot/build/px4_sitl_default/bin/px4
    """
    from rich.table import Table

    from vinecli.errors import ChecksFailed
    from vinecli.sitl.px4.doctor import px4_doctor

    rep = px4_doctor(px4_bin, instance=instance, host=host, probe_timeout_s=timeout)
    table = Table(title=f"PX4 SITL instance {instance}", show_lines=False)
    table.add_column("check")
    table.add_column("status")
    table.add_column("detail", overflow="fold")
    style = {"ok": "[green]ok[/]", "warn": "[yellow]warn[/]", "fail": "[bold red]FAIL[/]"}
    for c in rep.checks:
        table.add_row(c.name, style[c.status], c.detail)
    out_console.print(table)
    out_console.print("Start PX4 SITL against vinecli (then run with --autopilot px4"
                      + (f" --px4-instance {instance}" if instance else "") + "):")
    out_console.print(rep.start_command, markup=False, highlight=False, soft_wrap=True)
    if not rep.ok:
        raise ChecksFailed("px4 doctor: " + "; ".join(f"{c.name}: {c.detail}" for c in rep.checks if c.status == "fail"))
