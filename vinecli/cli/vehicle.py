"""``vinecli vehicle ...`` commands: fit a vehicle to a real flight log, replay a log through a vehicle."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from vinecli.cli.console import err_console, handles_errors, out_console, progress
from vinecli.cli.options import out_option, overwrite_option
from vinecli.identify.defaults import FIT_DEFAULTS

app = typer.Typer(help="Your drone, not ours: fit a vehicle to a PX4 or ArduPilot flight log, replay logs.",
                  no_args_is_help=True)

FIT_STAGES = ("reading the log", "thrust curve", "drag", "battery and power", "replaying the log", "writing")


def _num(v: Any, fmt: str = ".3g") -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, fmt)


def _errors_table(errors: dict[str, dict[str, Any]]) -> Any:
    from rich.table import Table

    keys = ("accel_rms_mps2", "velocity_rms_mps", "voltage_rms_v", "energy_error_fraction")
    t = Table(title="replay errors (lower is better)")
    t.add_column("model")
    for k in keys:
        t.add_column(k, justify="right")
    for name, e in errors.items():
        t.add_row(name, *(_num(e.get(k)) for k in keys))
    return t


@app.command("fit")
@handles_errors
def fit_cmd(
    log: Annotated[Path, typer.Argument(help="PX4 ULog (.ulg) or ArduPilot DataFlash (.bin) flight log.")],
    out: Annotated[Path, out_option("Output directory: vehicle.yaml, fit.json, replay.json, fit.html.")],
    base: Annotated[str, typer.Option("--base", help="Vehicle (name or YAML) the unidentified parameters come from.")
                    ] = FIT_DEFAULTS.base,
    mass: Annotated[float | None, typer.Option("--mass", help="Take-off mass, kg (a log gives forces per unit mass; "
                                                              "default: the base's).")] = None,
    name: Annotated[str | None, typer.Option("--name", help="Name of the fitted vehicle (default: <log>-fit).")] = None,
    overwrite: Annotated[bool, overwrite_option("Replace an existing output directory.")] = False,
) -> None:
    """Fit the thrust curve (hover throttle), drag, battery and power of the vehicle that flew LOG, with their
    uncertainty, and write a vehicle vinecli flies (the rest inherited from --base).

    Example: vinecli vehicle fit flight.ulg --base x500 --mass 1.6 --out my-drone
    """
    from vinecli.identify.fit import fit_vehicle

    with progress() as bar:
        task = bar.add_task("vehicle fit", total=len(FIT_STAGES), info="")

        def stage(what: str) -> None:
            bar.update(task, completed=FIT_STAGES.index(what) if what in FIT_STAGES else 0, info=what)

        r = fit_vehicle(log, out, base=base, mass_kg=mass, name=name, overwrite=overwrite, stage=stage)
    rep = r.report
    p = rep["parameters"]
    hc = rep.get("hover_check") or {}
    out_console.print(f"{r.log.info.firmware}, {r.log.config.frame}, {r.log.info.duration_s:.0f} s "
                      f"({rep['data']['airborne_samples']} airborne samples)")
    out_console.print(f"hover throttle {_num(rep['hover_throttle'], '.4f')} ± {_num(rep['hover_throttle_std'], '.4f')} "
                      f"({_num(rep['hover_pwm_us'], '.0f')} µs); the log hovers at {_num(hc.get('log_hover_output'), '.4f')} "
                      f"({_num(100 * hc['error_fraction'], '+.1f') if 'error_fraction' in hc else '-'} %)")
    for k in ("thrust_to_weight", "k_f", "body_drag_kg_per_m", "k_d", "internal_resistance_ohm_per_cell",
              "hover_power_w", "overall_figure_of_merit"):
        if k in p:
            v = p[k]
            out_console.print(f"  {k:34s} {_num(v['value'], '.4g'):>10} ± {_num(v['std'], '.2g'):<8} {v['unit']:14s} {v['source']}")
    en = rep.get("energy")
    if en:
        out_console.print(f"energy: log {en['log_wh']:.2f} Wh, model {en['model_wh']:.2f} Wh "
                          f"({100 * en['error_fraction']:+.1f} %)")
    if r.replay is not None:
        out_console.print(_errors_table(r.replay.errors))
    for note in rep["notes"]:
        err_console.print(f"note: {note}")
    out_console.print(f"{len(rep['fixed_from_base'])} parameters from the base {r.base.ref} (fit.json: fixed_from_base)")
    out_console.print(f"wrote {out}/vehicle.yaml, fit.json, replay.json, fit.html")


@app.command("replay")
@handles_errors
def replay_cmd(
    log: Annotated[Path, typer.Argument(help="PX4 ULog (.ulg) or ArduPilot DataFlash (.bin) flight log.")],
    vehicle: Annotated[str, typer.Option("--vehicle", help="Vehicle to replay (name or YAML, e.g. a fit's vehicle.yaml).")],
    out: Annotated[Path, out_option("Output directory: replay.json, replay.html.")],
    base: Annotated[str | None, typer.Option("--base", help="Unfitted baseline vehicle (default: the fitted vehicle's "
                                                            f"base, else {FIT_DEFAULTS.base}).")] = None,
    window: Annotated[float, typer.Option("--window", help="Open-loop window length, s.")] = FIT_DEFAULTS.window_s,
    overwrite: Annotated[bool, overwrite_option("Replace an existing output directory.")] = False,
) -> None:
    """Drive VEHICLE with LOG's motor outputs in still air over short open-loop windows (re-anchored to the
    log's state at each start) and compare specific force, body rates, velocity, voltage and energy with the
    log, next to the log's mean and the unfitted base vehicle.

    Example: vinecli vehicle replay flight.ulg --vehicle my-drone/vehicle.yaml --out replay
    """
    from vinecli.identify.vehicle_io import replay_vehicle

    rep = replay_vehicle(log, vehicle, out, base=base, window_s=window, overwrite=overwrite)
    out_console.print(_errors_table({"vehicle": rep["vehicle_errors"], **rep["baselines"]}))
    out_console.print(f"{rep['windows']} windows; wrote {out}/replay.json, replay.html")
