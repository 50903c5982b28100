"""``vinecli plan ...`` commands: spray plans from vine rows, QGroundControl .plan import."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from vinecli.cli.console import err_console, handles_errors, out_console
from vinecli.cli.options import out_option, overwrite_option, world_option
from vinecli.spray_defaults import SPRAY_DEFAULTS

app = typer.Typer(help="Spray plans: rows -> QGroundControl .plan, .plan -> mission, a sprayer's effective swath.",
                  no_args_is_help=True)


# parameters: Typer reads the command's options from its parameters, one per option
@app.command("rows")
@handles_errors
def rows_cmd(
    source: Annotated[Path, typer.Argument(help="A DSM GeoTIFF or a built world directory.")],
    out: Annotated[Path, out_option("The .plan file to write (OUT-stem.rows.geojson, WGS84, goes beside it).")],
    spacing: Annotated[float | None, typer.Option("--spacing", help="Expected row spacing, m (default: search 0.5-6 m).")] = None,
    height: Annotated[float, typer.Option("--height", help="Spray height above the canopy surface, m.")
                      ] = SPRAY_DEFAULTS.height_m,
    speed: Annotated[float, typer.Option("--speed", help="Ground speed along the rows, m/s.")] = SPRAY_DEFAULTS.speed_mps,
    flow: Annotated[float, typer.Option("--flow", help="Nozzle flow on the rows, L/s.")] = SPRAY_DEFAULTS.flow_lps,
    takeoff: Annotated[float, typer.Option("--takeoff", help="Take-off altitude above home, m.")
                       ] = SPRAY_DEFAULTS.takeoff_m,
    use_world_rows: Annotated[bool, typer.Option("--world-rows", help="World source: its rows (the default; error if none).")] = False,
    detect: Annotated[bool, typer.Option("--detect", help="World source: detect rows on its height grid instead.")] = False,
    vehicle: Annotated[str | None, typer.Option("--vehicle", help="Vehicle (speed/acceleration limits, tank); default: the world's, else x500-sprayer.")] = None,
    tank: Annotated[float | None, typer.Option("--tank", help="Litres per sortie (default: the vehicle's tank; 0: one sortie).")] = None,
    fence_margin: Annotated[float | None, typer.Option("--fence-margin", help="Keep the path this far inside the geofence, m (default 1; DSM source: inside its data extent, default 0).")] = None,
    home: Annotated[tuple[float, float] | None, typer.Option("--home", help="Take-off point X Y (ENU m of the source; default: the world's spawn / a corner row end).")] = None,
    mission_out: Annotated[Path | None, typer.Option("--mission", help="Also write the plan as a mission YAML.")] = None,
    overwrite: Annotated[bool, overwrite_option("Replace files of these names that exist.")] = False,
    rate: Annotated[float | None, typer.Option("--rate", help="Dose: L/ha of ground on every canopy segment (gaps 0); "
                                                              "writes OUT-stem.rates.json/.geojson.")] = None,
    dose_lwa: Annotated[float | None, typer.Option("--dose-lwa", help="Dose: litres per 10,000 m² of leaf wall area "
                                                                      "(EPPO PP 1/239), per segment.")] = None,
    dose_trv: Annotated[float | None, typer.Option("--dose-trv", help="Dose: litres per 10,000 m³ of tree-row volume, "
                                                                      "per segment.")] = None,
    sides: Annotated[int, typer.Option("--sides", help="Sides of each row treated (LWA): 1 or 2.")] = 2,
    prescription: Annotated[Path | None, typer.Option("--prescription", help="Dose from a prescription map: zones "
                            "(.gpkg .shp .geojson), a rate GeoTIFF or ISO-XML TaskData (TASKDATA.XML or its folder).")] = None,
    rate_column: Annotated[str | None, typer.Option("--rate-column", help="Zones: the rate column.")] = None,
    default_rate: Annotated[float | None, typer.Option("--default-rate", help="Rate outside the map's zones, L/ha.")] = None,
    rate_units: Annotated[str, typer.Option("--rate-units", help="Units of the map's rates: L/ha, gal/ac or mL/m2.")] = "L/ha",
    layer: Annotated[str | None, typer.Option("--layer", help="Zones: the layer (default: the first).")] = None,
    segment: Annotated[float, typer.Option("--segment", help="Canopy segment length along the rows, 1-5 m.")] = 2.0,
    foliage_base: Annotated[float, typer.Option("--foliage-base", help="Foliage base above the ground (the DSM "
                                                                       "cannot see under the leaves), m.")] = 0.0,
) -> None:
    """Detect vine rows (count, spacing, direction, confidence) and write an operator-style spray .plan:
    nearest row first, boustrophedon with headland turns sized from the vehicle's speed and acceleration,
    spray on over the rows only, terrain-following heights, one extra .plan per sortie when it needs
    more than one tank.

    Example: vinecli plan rows worlds/sample/fieldimager_potato_plots_dsm_3cm_utm16n.tif --out rows.plan
    """
    from vinecli.missions.rowjob import RowsPlanOptions, plan_rows_job
    from vinecli.missions.rowjob_dose import DoseOptions

    options = RowsPlanOptions(spacing=spacing, height=height, speed=speed, flow=flow, takeoff=takeoff, detect=detect,
                              world_rows=use_world_rows, vehicle=vehicle, tank_l=tank, fence_margin=fence_margin,
                              home=home)
    dose = DoseOptions(rate_lpha=rate, lwa_dose_l=dose_lwa, trv_dose_l=dose_trv, sides=sides, prescription=prescription,
                       rate_column=rate_column, default_rate_lpha=default_rate, rate_units=rate_units, layer=layer,
                       segment_m=segment, foliage_base_m=foliage_base)
    job = plan_rows_job(source, out, options, mission_out=mission_out, overwrite=overwrite, dose=dose)
    if job.detection is not None:
        out_console.print(escape(f"rows: {job.detection.summary()}"))
        if job.detection.confidence < 0.5:
            err_console.print(f"warning: no clear rows (confidence {job.detection.confidence:.2f})")
    else:
        out_console.print(f"rows: {len(job.rows)} rows of the world")
    for w in job.warnings:
        err_console.print(escape(f"warning: {w}"))
    out_console.print(escape(job.plan.summary()))
    if job.rates is not None:
        r = job.rates.summary()
        out_console.print(escape(f"dose {r['dose'] or 'from ' + str(prescription)}: {r['segments']} segments, "
                                 f"{r['rate_min_lpha']:.0f}-{r['rate_max_lpha']:.0f} L/ha (mean {r['rate_mean_lpha']:.0f}), "
                                 f"{r['gap_length_m']:.1f} m of gaps unsprayed; {r['litres']:.2f} L against "
                                 f"{r['uniform_litres']:.2f} L at a uniform {r['uniform_rate_lpha']:.0f} L/ha "
                                 f"({r['saving_pct']:.0f} % saved)"))
    sorties = f", {job.sorties} sorties (one .plan each)" if job.sorties > 1 else ""
    names = [p.name for p in job.files if ".sortie-" not in p.name]
    if job.sorties > 1:
        names.append(f"{out.stem}.sortie-{{1..{job.sorties}}}.plan")
    out_console.print(escape(f"{out}: {len(job.plan.order)} rows{sorties}; wrote {', '.join(names)}"))


@app.command("swath")
@handles_errors
def swath_cmd(
    out: Annotated[Path, out_option("Directory to write (swath.json, swath.png).")],
    vehicle: Annotated[str, typer.Option("--vehicle", help="Vehicle name (vehicles/<name>.yaml) or path.")] = "x500-sprayer",
    height: Annotated[float, typer.Option("--height", help="Spray height above the crop (skids), m.")
                      ] = SPRAY_DEFAULTS.height_m,
    speed: Annotated[float, typer.Option("--speed", help="Ground speed, m/s.")] = SPRAY_DEFAULTS.speed_mps,
    crosswind: Annotated[float, typer.Option("--crosswind", help="Wind across the passes, m/s (towards the left of a pass).")] = 0.0,
    cv_limit: Annotated[float, typer.Option("--cv-limit", help="CV of the overlapped deposit that defines the effective swath.")] = 0.10,
    band: Annotated[float, typer.Option("--band", help="Canopy band one pass doses, m (the single-pass width).")] = 0.6,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace OUT if it exists.")] = False,
) -> None:
    """The effective swath of a vehicle's sprayer from the deposition model (ASABE S386.2 style): prints it and
    plots the single-pass cross-track pattern, the overlapped pattern and the CV against the lane spacing.

    Example: vinecli plan swath --vehicle ag-hexa-16 --height 2.5 --speed 5 --out swath-hexa
    """
    from vinecli.report.swath_report import swath_report

    r = swath_report(vehicle, out, height_agl_m=height, speed_mps=speed, crosswind_mps=crosswind, cv_limit=cv_limit,
                     band_m=band, overwrite=overwrite)
    out_console.print(f"{r.vehicle} at {r.height_agl_m:g} m, {r.speed_mps:g} m/s, crosswind {r.crosswind_mps:g} m/s: "
                      f"effective swath {r.effective_m:.2f} m (CV {r.cv_at_effective:.1%} <= {r.cv_limit:.0%}), "
                      f"geometric {r.geometric_m:.2f} m, single pass over a {band:g} m band {r.single_pass_width_m:.2f} m")
    out_console.print(f"wrote {', '.join(str(p) for p in r.files)}")


@app.command("import")
@handles_errors
def import_cmd(
    plan: Annotated[Path, typer.Argument(help="QGroundControl .plan file.")],
    world: Annotated[Path, world_option("Built world directory (its geodetic origin).")],
    out: Annotated[Path, out_option("Mission YAML to write.")],
    spray_flow: Annotated[float | None, typer.Option("--spray-flow", help="Flow of DO_SPRAYER 'on', L/s.")] = None,
    name: Annotated[str | None, typer.Option("--name", help="Mission name (default: the file name).")] = None,
    overwrite: Annotated[bool, overwrite_option("Replace an existing OUT.")] = False,
) -> None:
    """Import a QGroundControl .plan as a mission YAML (DO_SET_ACTUATOR switches the sprayer).

    Example: vinecli plan import survey.plan --world build/vineyard --out missions/survey.yaml
    """
    from vinecli.missions.qgc_import import import_plan_for_world

    mission = import_plan_for_world(plan, world, out, spray_flow_lps=spray_flow, name=name, overwrite=overwrite)
    out_console.print(escape(f"{out}: {len(mission.phases)} phases"
                             + (", with geofence" if mission.geofence is not None else "")))
