"""``vinecli terrain ...`` commands."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from vinecli.cli.console import handles_errors, out_console

app = typer.Typer(help="Turn DSMs and point clouds into simulator terrain.", no_args_is_help=True)


@app.command("reconstruct")
@handles_errors
def reconstruct(
    cloud: Annotated[Path, typer.Argument(help="Point cloud: .las .laz .ply .pcd .xyz/.txt/.csv", show_default=False)],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output directory (mesh.obj, stats.json, manifest.json).",
                                      show_default=False)],
    method: Annotated[str, typer.Option("--method", help="bpa (ball pivoting) or delaunay25d (hole-free 2.5-D).")
                      ] = "bpa",
    voxel: Annotated[float | None, typer.Option("--voxel", metavar="M",
                                                help="Voxel edge in m (default 2x median spacing; 0 = none).")] = None,
    radii: Annotated[str | None, typer.Option("--radii", metavar="R1,R2,...",
                                              help="Ball-pivoting radii in m (default 2d,4d,8d).")] = None,
    classes: Annotated[str | None, typer.Option("--classes", metavar="C1,...",
                                                help="Keep only these LAS classes (2 = ground).")] = None,
    bbox: Annotated[str | None, typer.Option("--bbox", metavar="MINX,MINY,MAXX,MAXY",
                                             help="Keep points inside, in the file's CRS units.")] = None,
    dsm: Annotated[float | None, typer.Option("--dsm", metavar="RES",
                                              help="Also write dsm.tif (max z per cell) at RES m.")] = None,
    max_points: Annotated[int | None, typer.Option("--max-points", metavar="N",
                                                   help="Enlarge the voxel until at most N points remain.")] = None,
    max_edge: Annotated[float | None, typer.Option("--max-edge", metavar="M",
                                                   help="delaunay25d: peel hull triangles with edges > M m.")] = None,
    no_fill: Annotated[bool, typer.Option("--no-fill-holes", help="bpa: skip hole filling.")] = False,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace a non-empty --out.")] = False,
) -> None:
    """Mesh a point cloud (ball pivoting or 2.5-D Delaunay) into mesh.obj + stats.json.

    Example: vinecli terrain reconstruct field.laz --out field-mesh --classes 2 --dsm 0.5
    """
    from vinecli.terrain.pointcloud import ReconstructOptions, parse_list, reconstruct_cloud

    options = ReconstructOptions(
        method=method,  # type: ignore[arg-type]  # validated by ReconstructOptions.validate
        voxel=voxel, radii=parse_list(radii, "--radii"), classes=parse_list(classes, "--classes", int),
        bbox=parse_list(bbox, "--bbox", float, 4), dsm_res=dsm, max_points=max_points, max_edge=max_edge,
        fill_holes=not no_fill, overwrite=overwrite)
    stats = reconstruct_cloud(cloud, out, options)
    _render_reconstruct(stats, out)


def _render_reconstruct(stats: dict, out: Path) -> None:
    """One rich table with what reconstruct did."""
    from rich.table import Table

    p, m, b = stats["points"], stats["mesh"], stats["mesh_before_fill"]
    t = Table(title=f"terrain reconstruct -> {out}", show_header=False, title_justify="left")
    t.add_column(style="bold")
    t.add_column()
    t.add_row("points", f"{p['in']:,} in, -{p['nan_dropped']:,} NaN, -{p['duplicates_removed']:,} duplicates, "
                        f"-{p['class_filtered_out'] + p['bbox_filtered_out']:,} filtered, {p['used']:,} used")
    t.add_row("units / CRS", f"{stats['units']['xy_unit']} / {(stats['crs'] or {}).get('name', 'none')}")
    t.add_row("offset (m)", ", ".join(f"{v:.0f}" for v in stats["offset_m"]))
    t.add_row("voxel / spacing d", f"{stats['voxel_m']:.3f} m / {stats['spacing_m']['d']:.3f} m")
    if stats.get("radii_m"):
        t.add_row("radii (m)", ", ".join(f"{r:.3f}" for r in stats["radii_m"]))
    t.add_row("method", stats["method"])
    t.add_row("triangles", f"{m['triangles']:,}")
    t.add_row("holes", f"{b['holes']} before filling, {m['holes']} after")
    t.add_row("components", str(m["components"]))
    t.add_row("non-manifold edges", str(m["non_manifold_edges"]))
    t.add_row("area", f"{m['area_m2']:,.1f} m²")
    if stats.get("dsm"):
        d = stats["dsm"]
        t.add_row("dsm.tif", f"{d['width']} x {d['height']} at {d['resolution_m']} m, "
                             f"{100 * d['filled_fraction']:.1f}% cells filled (nearest)")
    t.add_row("seconds", ", ".join(f"{k} {v:.2f}" for k, v in stats["seconds"].items()))
    out_console.print(t)
