"""``vinecli plan ...`` commands: spray plans from vine rows, QGroundControl .plan import."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from vinecli.cli.console import handles_errors, out_console

app = typer.Typer(help="Spray plans: rows -> QGroundControl .plan, .plan -> mission.", no_args_is_help=True)


@app.command("rows")
@handles_errors
def rows_cmd(
    source: Annotated[Path, typer.Argument(help="A DSM GeoTIFF or a built world directory.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="The .plan file to write.")],
    spacing: Annotated[float | None, typer.Option("--spacing", help="Expected row spacing, m (default: search 0.5-6 m).")] = None,
    height: Annotated[float, typer.Option("--height", help="Spray height above the terrain, m.")] = 2.0,
    speed: Annotated[float, typer.Option("--speed", help="Ground speed along the rows, m/s.")] = 1.5,
    flow: Annotated[float, typer.Option("--flow", help="Nozzle flow on the rows, L/s.")] = 0.05,
    use_world_rows: Annotated[bool, typer.Option("--world-rows", help="World source: use its rows, do not detect.")] = False,
    mission_out: Annotated[Path | None, typer.Option("--mission", help="Also write the plan as a mission YAML.")] = None,
) -> None:
    """Detect vine rows (direction, spacing, centre lines) and write a boustrophedon spray .plan.

    Example: vinecli plan rows worlds/sample/vineyard.tif --out spray.plan --spacing 2.5
    """
    from vinecli.errors import InputError
    from vinecli.missions import patterns
    from vinecli.missions.qgc_plan import export_plan, write_plan
    from vinecli.names import name_from

    nozzle = 0.1
    if source.is_dir():
        from vinecli.world import load_world

        world = load_world(source)
        origin, home = world.origin, tuple(world.spawn_enu)
        if world.vehicle.tank is not None:
            nozzle = world.vehicle.tank.nozzle_max_flow_lps
        if use_world_rows:
            if not world.vine_rows_enu:
                raise InputError("the world has no rows", path=source)
            rows = [list(map(tuple, r)) for r in world.vine_rows_enu]
            det = None
        else:
            det, origin, home = patterns.detect_rows_in_world(source, spacing_m=spacing)
            rows = det.rows
    else:
        if use_world_rows:
            raise InputError("--world-rows needs a world directory", path=source)
        det, origin = patterns.detect_rows_in_dsm(source, spacing_m=spacing)
        home, rows = (0.0, 0.0, 0.0), det.rows
    if not rows:
        raise InputError("no rows found (try --spacing)", path=source)
    mission = patterns.spray_mission(rows, name=name_from(out.stem, "spray-rows"), height_m=height, speed_mps=speed,
                                     flow_lps=flow)
    plan = export_plan(mission, origin, home, nozzle_max_flow_lps=nozzle)  # type: ignore[arg-type]
    write_plan(out, plan)
    if mission_out is not None:
        from vinecli.missions.spec_io import write_mission

        write_mission(mission_out, mission)
    if det is not None:
        out_console.print(f"rows: direction {det.direction_deg:.1f} deg (ENU, from east), spacing {det.spacing_m:.3f} m, "
                          f"{len(det.rows)} rows, peak strength {det.strength:.0f}")
    n_items = len(plan["mission"]["items"])
    out_console.print(f"{out}: {n_items} mission items over {len(rows)} rows")


@app.command("import")
@handles_errors
def import_cmd(
    plan: Annotated[Path, typer.Argument(help="QGroundControl .plan file.")],
    world: Annotated[Path, typer.Option("--world", "-w", help="Built world directory (its geodetic origin).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Mission YAML to write.")],
    spray_flow: Annotated[float | None, typer.Option("--spray-flow", help="Flow of DO_SPRAYER 'on', L/s.")] = None,
    name: Annotated[str | None, typer.Option("--name", help="Mission name (default: the file name).")] = None,
) -> None:
    """Import a QGroundControl .plan as a mission YAML (DO_SET_ACTUATOR switches the sprayer).

    Example: vinecli plan import survey.plan --world build/vineyard --out missions/survey.yaml
    """
    from vinecli.missions.qgc_plan import import_plan
    from vinecli.missions.spec_io import write_mission
    from vinecli.world import load_world

    w = load_world(world)
    nozzle = w.vehicle.tank.nozzle_max_flow_lps if w.vehicle.tank is not None else 0.1
    mission = import_plan(plan, w.origin, nozzle_max_flow_lps=nozzle, spray_flow_lps=spray_flow, name=name)
    write_mission(out, mission)
    out_console.print(f"{out}: {len(mission.phases)} phases"
                      + (", with geofence" if mission.geofence is not None else ""))
