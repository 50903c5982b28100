"""``vinecli gis`` commands: a run's rows, passes, sprayed stretches, gaps and deposition map out to GIS."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from vinecli.cli.console import handles_errors, out_console
from vinecli.cli.options import overwrite_option

app = typer.Typer(help="GIS files out of runs (GeoPackage, RFC 7946 GeoJSON).", no_args_is_help=True)


@app.command("export")
@handles_errors
def export_cmd(
    run_dir: Annotated[Path, typer.Argument(help="A run directory (vinecli run mission --out RUNS: RUNS/<run_id>).")],
    out: Annotated[Path, typer.Option("--out", help="FILE.gpkg (one layer each) or FILE.geojson (WGS84, a 'layer' "
                                                    "property per feature).")],
    overwrite: Annotated[bool, overwrite_option("Replace an existing --out file (and its map).")] = False,
    with_map: Annotated[bool, typer.Option("--map/--no-map", help="Also write the run's field map (the report's "
                                                                  "Leaflet map, offline) beside it as FILE.gpkg.html.")
                        ] = True,
) -> None:
    """Rows, passes, sprayed stretches, gaps, the deposition map (rate classes), fence and no-spray zones of a run,
    in WGS84 through the world's CRS: they open in place over the DSM in QGIS; and the run's field map as FILE.gpkg.html.

    Example: vinecli gis export runs/spray-s0 --out spray.gpkg   (spray.gpkg and spray.gpkg.html)
    """
    from vinecli.report.fieldmap.export import export_run_gis_with_map

    for path in export_run_gis_with_map(run_dir, out, overwrite=overwrite, with_map=with_map):
        out_console.print(f"wrote {path}")
