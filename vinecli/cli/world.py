"""``vinecli world ...`` commands."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from vinecli.cli.console import handles_errors, out_console
from vinecli.cli.options import out_option, overwrite_option

app = typer.Typer(help="Build simulator worlds from terrain, vehicles and wind.", no_args_is_help=True)


@app.command("build")
@handles_errors
def build(
    spec: Annotated[Path, typer.Argument(help="World file (worlds/*.yaml).")],
    out: Annotated[Path, out_option("Output world directory.")],
    overwrite: Annotated[bool, overwrite_option("Replace an existing output directory.")] = False,
    allow_unsafe_spawn: Annotated[bool, typer.Option(
        "--allow-unsafe-spawn", help="Build even when the spawn cannot pass preflight (near the geofence, tilted).")] = False,
) -> None:
    """Build a world directory: world.json, terrain, vehicle URDF and a Gazebo world.sdf.

    Example: vinecli world build worlds/vineyard-sample.yaml --out build/vineyard
    """
    from vinecli.world import build_world, load_world

    path = build_world(spec, out, overwrite=overwrite, allow_unsafe_spawn=allow_unsafe_spawn)
    w = load_world(path)
    xmin, ymin, xmax, ymax = w.terrain.bounds
    n_tiles = sum(f.suffix.lower() in (".obj", ".stl") for f in w.terrain.files)
    tiles = f", {n_tiles} tiles" if n_tiles else ""
    out_console.print(
        f"world [bold]{w.name}[/] -> {escape(str(path))}: terrain {w.terrain.kind} "
        f"({xmax - xmin:.1f} m × {ymax - ymin:.1f} m{tiles}), vehicle {w.vehicle.name}, "
        f"origin {w.origin.lat:.6f}, {w.origin.lon:.6f}, {w.origin.alt:.1f} m, {len(w.vine_rows_enu)} rows",
        markup=True,
    )
    if w.canopy:
        c = w.canopy
        hs = c.get("hedges") or []
        tops = [h["top_m"] for h in hs]
        out_console.print(
            f"canopy ({c['source']}, BBCH {c['bbch']}): {len(hs)} hedges, top {min(tops, default=0):.2f}-"
            f"{max(tops, default=0):.2f} m, width {hs[0]['width_m'] if hs else 0:.2f} m, LAD "
            f"{hs[0]['lad_m2m3'] if hs else 0:.1f} m²/m³, LAI {c['lai']:.2f}" if hs else "canopy: no hedges (no rows)")
    segs = (w.canopy or {}).get("segments")
    if segs:
        from vinecli.rows.canopy_segments import summary_text

        out_console.print(escape(f"canopy segments: {summary_text(segs)}; wrote {', '.join(segs['files'])}"))
    if w.rows_detection:
        d = w.rows_detection
        out_console.print(escape(f"rows (auto, from the {d['source']}): {d['count']} rows, spacing {d['spacing_m']:.3f} m, "
                                 f"direction {d['direction_deg']:.1f} deg from east, confidence {d['confidence']:.2f}"))
