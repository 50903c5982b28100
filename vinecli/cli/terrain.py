"""``vinecli terrain ...`` commands."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from vinecli.cli.console import PlainTable, handles_errors, out_console
from vinecli.cli.options import out_option, overwrite_option
from vinecli.terrain.defaults import FILL, HEIGHTMAP_METHOD, RECONSTRUCT_METHOD, TILE_FORMAT, TILE_PX

app = typer.Typer(help="Turn DSMs and point clouds into simulator terrain.", no_args_is_help=True)


# parameters: Typer reads the command's options from its parameters, one per option
@app.command("reconstruct")
@handles_errors
def reconstruct(
    cloud: Annotated[Path, typer.Argument(help="Point cloud: .las .laz .ply .pcd .xyz/.txt/.csv", show_default=False)],
    out: Annotated[Path, out_option("Output directory (mesh.obj, stats.json, manifest.json).")],
    method: Annotated[str, typer.Option("--method", help="bpa (ball pivoting) or delaunay25d (hole-free 2.5-D).")
                      ] = RECONSTRUCT_METHOD,
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
    overwrite: Annotated[bool, overwrite_option("Replace a non-empty --out.")] = False,
) -> None:
    """Mesh a point cloud (ball pivoting or 2.5-D Delaunay) into mesh.obj + stats.json.

    Example: vinecli terrain reconstruct field.laz --out field-mesh --classes 2 --dsm 0.5
    """
    from vinecli.terrain.pointcloud.reconstruct import ReconstructOptions, parse_list, reconstruct_cloud

    options = ReconstructOptions(
        method=method,  # type: ignore[arg-type]  # validated by ReconstructOptions.validate
        voxel=voxel, radii=parse_list(radii, "--radii"), classes=parse_list(classes, "--classes", int),
        bbox=parse_list(bbox, "--bbox", float, 4), dsm_res=dsm, max_points=max_points, max_edge=max_edge,
        fill_holes=not no_fill, overwrite=overwrite)
    stats = reconstruct_cloud(cloud, out, options)
    _render_reconstruct(stats, out)


def _render_reconstruct(stats: dict, out: Path) -> None:
    """One rich table with what reconstruct did."""

    p, m, b = stats["points"], stats["mesh"], stats["mesh_before_fill"]
    t = PlainTable(title=escape(f"terrain reconstruct -> {out}"), show_header=False, title_justify="left")
    t.add_column(style="bold")
    t.add_column()
    t.add_row("points", f"{p['in']:,} in, -{p['nan_dropped']:,} NaN, -{p['duplicates_removed']:,} duplicates, "
                        f"-{p['class_filtered_out'] + p['bbox_filtered_out']:,} filtered, {p['used']:,} used")
    t.add_row("units / CRS", f"{stats['units']['xy_unit']} -> metres / {(stats['crs'] or {}).get('name', 'none')}")
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


# parameters: Typer reads the command's options from its parameters, one per option
@app.command("convert")
@handles_errors
def convert(
    dsm: Annotated[Path, typer.Argument(help="DSM/DEM GeoTIFF (.tif/.tiff), single band.", show_default=False)],
    to: Annotated[str, typer.Option("--to", help="heightmap (square 2^n+1 grid) or tiles (crack-free meshes).",
                                    show_default=False)],
    out: Annotated[Path, out_option("Output directory (must be new or empty).")],
    size: Annotated[int | None, typer.Option("--size", metavar="N",
                                             help="heightmap: side N = 2^n+1, at most 1025 (default: suggested).")
                    ] = None,
    method: Annotated[str, typer.Option("--method", help="heightmap: bilinear, cubic, average, max or nearest "
                                                         "(max keeps vine-row tops when downsampling).")
                      ] = HEIGHTMAP_METHOD,
    window: Annotated[str | None, typer.Option("--window", metavar="COL,ROW,WIDTH,HEIGHT",
                                               help="heightmap: crop to this pixel window (centred square).")
                      ] = None,
    bbox: Annotated[str | None, typer.Option("--bbox", metavar="MINX,MINY,MAXX,MAXY",
                                             help="heightmap: crop to this box in the DSM's CRS units.")] = None,
    fill: Annotated[str, typer.Option("--fill", help="Nodata fill: idw, nearest, min, or a height in m.")] = FILL,
    z_unit: Annotated[str | None, typer.Option("--z-unit", help="Override the height unit: m, ft or us-ft.")
                      ] = None,
    max_error: Annotated[float | None, typer.Option("--max-error", metavar="M",
                                                    help="tiles: max vertical error per tile in m (default 0.1).")
                         ] = None,
    max_triangles: Annotated[int | None, typer.Option("--max-triangles", metavar="K",
                                                      help="tiles: triangle budget per tile instead of/with "
                                                           "--max-error.")] = None,
    tile_px: Annotated[int, typer.Option("--tile-px", metavar="P",
                                         help="tiles: tile step in pixels; neighbours share a border row/column.")
                       ] = TILE_PX,
    fmt: Annotated[str, typer.Option("--format", help="tiles: obj or stl (binary).")] = TILE_FORMAT,
    workers: Annotated[int | None, typer.Option("--workers", help="tiles: worker processes (default: CPUs).")
                       ] = None,
    overwrite: Annotated[bool, overwrite_option("Replace a non-empty --out.")] = False,
) -> None:
    """Convert a DSM into a PyBullet/Gazebo heightmap or into error-bounded mesh tiles.

    Examples: vinecli terrain convert field.tif --to heightmap --size 513 --method max --out hm;
    vinecli terrain convert field.tif --to tiles --max-error 0.05 --tile-px 256 --out tiles
    """
    from vinecli.terrain.convert import convert_dsm

    result = convert_dsm(dsm, out, to=to, size=size, method=method, window=window, bbox=bbox, fill=fill,
                         z_unit=z_unit, max_error=max_error, max_triangles=max_triangles, tile_px=tile_px, fmt=fmt,
                         workers=workers, overwrite=overwrite)
    (_render_heightmap if to == "heightmap" else _render_tiles)(result.meta, out)


def _origin_text(geo: dict | None) -> str:
    if not geo:
        return "unknown (no CRS)"
    return f"{geo['lat']:.7f}°, {geo['lon']:.7f}°, {geo['alt']:.2f} m"


def _render_heightmap(m: dict, out: Path) -> None:
    """One rich table about a written heightmap."""

    t = PlainTable(title=escape(f"terrain convert --to heightmap -> {out}"), show_header=False, title_justify="left")
    t.add_column(style="bold")
    t.add_column()
    n = m["size_px"]
    t.add_row("grid", f"{n} x {n} vertices, spacing {m['spacing_m']:.4g} m, side {m['size_m'][0]:.4g} m")
    t.add_row("heights", f"{m['z_min']:.3f} .. {m['z_max']:.3f} m, PNG step {1000 * m['height_step_m']:.3f} mm")
    t.add_row("crop", f"{m['crop']['mode']}" + (" (cut to its centred square)" if m["crop"]["trimmed_to_square"]
                                                else ""))
    t.add_row("resampling", f"{m['resampling']}; read: {m['read']}")
    t.add_row("nodata filled", f"{100 * m['nodata_filled_fraction']:.2f}% ({m['fill_method']})")
    loss = m.get("resolution_loss")
    if loss and loss.get("samples"):
        t.add_row("resolution loss", f"RMS {loss['rms_m']:.3f} m, max {loss['max_abs_m']:.3f} m vs the DSM samples")
    t.add_row("CRS", str(m["crs"] if m["crs"] is None or len(str(m["crs"])) < 40 else "custom (WKT)"))
    t.add_row("geodetic origin", _origin_text(m["geodetic_origin"]))
    t.add_row("files", "heightmap.png (16-bit), heightmap.tif (float32), heightmap.json, manifest.json")
    for w in m.get("warnings", []):
        t.add_row("warning", w)
    out_console.print(t)


def _render_tiles(m: dict, out: Path) -> None:
    """One rich table about written mesh tiles."""

    tot = m["totals"]
    t = PlainTable(title=escape(f"terrain convert --to tiles -> {out}"), show_header=False, title_justify="left")
    t.add_column(style="bold")
    t.add_column()
    t.add_row("tiles", f"{tot['tiles']} ({m['tile_grid'][0]} x {m['tile_grid'][1]}), {m['mesh_format']}, "
                       f"step {m['tile_px']} px")
    t.add_row("triangles", f"{tot['triangles']:,} = {100 * tot['triangle_ratio']:.1f}% of the full grid "
                           f"({tot['full_grid_triangles']:,})")
    bound = f" (bound {m['max_error_m']:g} m)" if m["error_bound_enforced"] else " (triangle budget)"
    t.add_row("vertical error", f"max {tot['max_error_m']:.4f} m{bound}, RMS {tot['rms_error_m']:.4f} m")
    t.add_row("border gap", f"{tot['max_border_gap_m']:.3g} m (shared border vertices)")
    t.add_row("nodata filled", f"{100 * m['nodata_filled_fraction']:.2f}% ({m['fill_method']})")
    t.add_row("origin", f"CRS {m['origin']['crs_xy'][0]:.3f}, {m['origin']['crs_xy'][1]:.3f}; "
                        f"geodetic {_origin_text(m['origin']['geodetic'])}")
    t.add_row("seconds", ", ".join(f"{k} {v:.2f}" for k, v in m["seconds"].items()) + f" ({m['workers']} workers)")
    out_console.print(t)


@app.command("info")
@handles_errors
def info(
    file: Annotated[Path, typer.Argument(help="DSM GeoTIFF or point cloud (.las .laz .ply .pcd .xyz).",
                                         show_default=False)],
    as_json: Annotated[bool, typer.Option("--json", help="Print the facts as JSON instead of a table.")] = False,
    canopy: Annotated[bool, typer.Option("--canopy", help="DSM: also detect the rows and measure their canopy "
                                                          "segment by segment (docs/dose.md).")] = False,
    foliage_base: Annotated[float, typer.Option("--foliage-base", metavar="M",
                                                help="--canopy: foliage base above the ground, m.")] = 0.0,
    segment: Annotated[float, typer.Option("--segment", metavar="M", help="--canopy: segment length, 1-5 m.")] = 2.0,
) -> None:
    """One screen about a raster or point cloud and what convert/reconstruct would do with it.

    Example: vinecli terrain info field.tif --canopy --foliage-base 0.5
    """
    from vinecli.terrain.info import describe

    facts = describe(file)
    if canopy and facts.get("kind") == "raster":
        from vinecli.errors import check_range
        from vinecli.rows.dsm_canopy import measure_dsm_canopy

        check_range("--foliage-base", foliage_base, 0.0, 20.0)
        check_range("--segment", segment, 1.0, 5.0)
        facts["canopy"] = measure_dsm_canopy(file, base_m=foliage_base, segment_m=segment).segments.summary()
    if as_json:
        import json

        from vinecli.outputs import jsonable

        typer.echo(json.dumps(jsonable(facts), indent=2))
        return
    if facts.get("kind") == "raster":
        _render_raster_info(facts)
    else:
        _render_generic(facts)


def _render_raster_info(f: dict) -> None:

    t = PlainTable(title=escape(f"terrain info {f['file']}"), show_header=False, title_justify="left")
    t.add_column(style="bold")
    t.add_column()
    u = f["units"]
    t.add_row("size", f"{f['size_px'][0]} x {f['size_px'][1]} px, {f['dtype']}, {f['layout']}")
    t.add_row("CRS", f"{f['crs'] or 'none'} - {f['crs_name'] or 'coordinates taken as metres'} ({f['crs_kind']})")
    t.add_row("units", f"xy {u['xy_unit']}, z {u['z_unit']} ({u['z_source']})")
    t.add_row("resolution", f"{f['pixel_size'][0]:.6g} x {f['pixel_size'][1]:.6g} CRS units = "
                            f"{f['pixel_size_m'][0]:.4g} x {f['pixel_size_m'][1]:.4g} m")
    t.add_row("extent", f"{f['extent_m'][0]:.1f} x {f['extent_m'][1]:.1f} m")
    t.add_row("centre", _origin_text({**f["geodetic_centre"], "alt": float("nan")}).rsplit(",", 1)[0]
              if f["geodetic_centre"] else "unknown (no CRS)")
    t.add_row("nodata", f"{100 * f['nodata_fraction']:.3f}% (value {f['nodata_value']})")
    z = f"{f['z_min_m']:.3f} .. {f['z_max_m']:.3f} m (relief {f['relief_m']:.3f} m)" if f["z_min_m"] is not None \
        else "no valid heights"
    t.add_row("z range", z)
    h = f["convert"]["heightmap"]
    t.add_row("convert heightmap",
              f"centred square {h['square_crop_m']:.1f} m ({h['square_crop_px']:.0f} px) on {h['grid']}; "
              f"--size {h['suggested_size']} -> spacing {h['spacing_m']:.3g} m, x{h['downsampling_factor']:.2f} "
              f"resampling, --method {h['suggested_method']}; PNG step {1000 * h['height_step_m']:.2f} mm; "
              f"read: {h['read']}")
    t.add_row("PyBullet heightfield", f"~{h['pybullet_heightfield_mb']:.0f} MB at {h['suggested_size']}², "
                                      f"{'within' if h['pybullet_ok'] else 'ABOVE'} the 2^21-sample limit")
    tl = f["convert"]["tiles"]
    t.add_row("convert tiles", f"{tl['tile_grid'][0]} x {tl['tile_grid'][1]} tiles of {tl['tile_px']} px, "
                               f"full grid {tl['full_grid_triangles']:,} triangles "
                               f"(~{tl['pybullet_mb_full_grid']:.0f} MB in PyBullet), fewer at "
                               f"--max-error {tl['max_error_m']} m")
    if f.get("canopy"):
        from vinecli.rows.canopy_segments import summary_text

        t.add_row("canopy", escape(summary_text(f["canopy"])))
    for w in f.get("warnings", []):
        t.add_row("warning", w)
    out_console.print(t)


def _render_generic(f: dict) -> None:

    t = PlainTable(title=escape(f"terrain info {f.get('file', '')}"), show_header=False, title_justify="left")
    t.add_column(style="bold")
    t.add_column()
    for k, v in f.items():
        if isinstance(v, dict):
            v = ", ".join(f"{kk}: {vv}" for kk, vv in v.items())
        t.add_row(str(k), str(v))
    out_console.print(t)
