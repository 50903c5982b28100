"""``vinecli world build``: WorldSpec YAML -> a world directory (see :mod:`vinecli.world.model`).

DIR/world.json, DIR/terrain/ (grid.npz + heightmap or tiles), DIR/vehicles/<name>.urdf,
DIR/world.sdf and DIR/manifest.json, written atomically.
"""

from __future__ import annotations

import json
import logging
import math
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from vinecli.autopilot.preflight import PreflightFailure, check_spawn_fence, check_tilt, fence_margins_m
from vinecli.errors import InputError, SpecError
from vinecli.geo import GeoOrigin
from vinecli.gis.read import gis_files
from vinecli.inputs import note_input, reading_inputs
from vinecli.outputs import Manifest, atomic_output_dir, contained_path, write_json
from vinecli.specs import load_spec
from vinecli.specs.refs import SPEC_SUFFIXES, spec_reference
from vinecli.specs.vehicle import VehicleSpec
from vinecli.terrain.grid import TerrainGrid
from vinecli.world.gis_inputs import gis_sources
from vinecli.world.model import SCHEMA, TerrainInfo, rest_position
from vinecli.world.spec import DsmTerrain, FlatTerrain, WorldSpec

__all__ = ["build_world", "world_spec_inputs"]

log = logging.getLogger(__name__)


def _resolve(base: Path, p: Path) -> Path:
    return p if p.is_absolute() else (base / p)


def build_world(spec_path: Path | str, out: Path | str, *, overwrite: bool = False,
                allow_unsafe_spawn: bool = False) -> Path:
    """Build the world described by ``spec_path`` into ``out``; returns ``out``.

    A spawn that cannot pass the autopilot's preflight (:mod:`vinecli.autopilot.preflight`:
    within the position-uncertainty margin of the geofence, or tilted beyond
    ``control.preflight_max_tilt_deg`` at rest) raises SpecError (nothing is written) unless
    ``allow_unsafe_spawn`` (then a warning).
    """
    spec_path = Path(spec_path)
    out = Path(out)
    with reading_inputs() as inputs:  # the spec, its base: chain, the vehicle and terrain it names
        spec, vehicle = world_spec_inputs(spec_path)
        return _build(spec_path, spec, vehicle, out, [i.path for i in inputs], overwrite, allow_unsafe_spawn)


def world_spec_inputs(spec_path: Path) -> tuple[WorldSpec, VehicleSpec]:
    """Read a world spec and the vehicle it names, noting every file it reads or names (the spec and its
    ``base:`` chain, the vehicle file, the terrain source, the GIS files) as inputs of the running command
    (:mod:`vinecli.inputs`)."""
    from vinecli.vehicle import load_vehicle

    spec = load_spec(spec_path, WorldSpec)
    base = spec_path.resolve().parent
    for src in _terrain_sources(spec.terrain):
        note_input(_resolve(base, Path(src)), "terrain source")
    for src in gis_sources(spec.gis, base):
        for part in gis_files(src):  # a Shapefile's .shx, .dbf, .prj... too; refused early when one is missing
            note_input(part, "GIS file")
    veh_arg: str | Path = spec.vehicle
    if spec.vehicle.endswith(SPEC_SUFFIXES) or "/" in spec.vehicle:
        veh_arg = spec_reference(spec.vehicle, spec_path, "vehicle")
    return spec, load_vehicle(veh_arg)


def _build(spec_path: Path, spec: WorldSpec, vehicle: VehicleSpec, out: Path, inputs: list[Path], overwrite: bool,
           allow_unsafe_spawn: bool) -> Path:
    """:func:`build_world` once the spec and its inputs are read."""
    from vinecli.vehicle.urdf import write_urdf
    from vinecli.world.sdf import world_sdf

    base = spec_path.resolve().parent
    man = Manifest(command="world build", parameters={"spec": str(spec_path), "out": str(out)}, inputs=inputs)
    given_origin = GeoOrigin(spec.origin.lat, spec.origin.lon, spec.origin.alt) if spec.origin else None
    unsafe = _refuse_unsafe(spec_path, allow_unsafe_spawn)
    gnss = vehicle.sensors.gnss  # the margin the autopilot's estimator will need
    margin_h = fence_margins_m(gnss.horizontal_noise_m, gnss.vertical_noise_m)[0]
    if spec.geofence is not None:  # horizontal check only: no terrain needed, nothing written yet
        unsafe(check_spawn_fence(spec.geofence, (spec.spawn.x_m, spec.spawn.y_m, 0.0), margin_h))

    with atomic_output_dir(out, man, overwrite=overwrite) as tmp:
        tdir = tmp / "terrain"
        t = spec.terrain
        with man.stage("terrain"):
            terrain_json, sdf_terrain, grid, origin = _terrain(t, tdir, tmp, base, given_origin, spec_path, man)

        info = TerrainInfo(kind=terrain_json["kind"], grid=grid, flat_z=float(terrain_json.get("flat_z", 0.0)))
        if not tdir.exists():
            tdir.mkdir()
        xmin, ymin, xmax, ymax = terrain_json["bounds_enu"]
        sx, sy = spec.spawn.x_m, spec.spawn.y_m
        if not (xmin <= sx <= xmax and ymin <= sy <= ymax):
            raise SpecError(f"spawn ({sx}, {sy}) is outside the terrain {terrain_json['bounds_enu']}", path=spec_path)
        spawn = rest_position(info, vehicle, sx, sy)
        yaw = math.radians(spec.spawn.yaw_deg)

        with man.stage("vehicle"):
            urdf = write_urdf(vehicle, contained_path(tmp, "vehicles", f"{vehicle.name}.urdf"))
            (contained_path(tmp, "vehicles", f"{vehicle.name}.json")).write_text(vehicle.model_dump_json(indent=1))

        with man.stage("spawn"):
            rest = _rest_at_spawn(terrain_json, tmp, grid, vehicle, urdf, spawn, spec)
        unsafe(check_tilt(math.radians(rest["tilt_deg"]), vehicle))
        if rest["tilt_deg"] > MAX_REST_TILT_DEG:
            log.warning("world %s: the vehicle rests %.1f deg tilted at the spawn (%.2f, %.2f) (more than %.0f deg): "
                        "move the spawn to a flat spot", spec.name, rest["tilt_deg"], sx, sy, MAX_REST_TILT_DEG)

        rows = [] if spec.rows in (None, "auto") else [[list(p) for p in row] for row in spec.rows]
        rows_detection = None
        if spec.rows == "auto":
            with man.stage("rows"):
                rows, rows_detection = _auto_rows(t, base, terrain_json, tdir, grid, spec.name, spec.geofence)
        geofence, rows, gis_doc = spec.geofence, [[tuple(p) for p in r] for r in rows], None
        if spec.gis is not None:
            with man.stage("gis"):
                geofence, rows, gis_doc = _gis(spec, base, terrain_json, tdir, origin, rows)
            unsafe(check_spawn_fence(geofence, (sx, sy, 0.0), margin_h))
        canopy = None
        if spec.canopy is not None:
            from vinecli.world.canopy_build import resolve_canopy

            width = spec.canopy_width_m if "canopy_width_m" in spec.model_fields_set else None
            canopy = resolve_canopy(spec.canopy, rows, grid.heights if grid is not None else None, width, str(spec_path))
            with man.stage("canopy segments"):
                canopy_doc = _canopy_segments(spec, canopy, grid, tmp, terrain_json, tdir, origin)
        doc = {
            "schema": SCHEMA,
            "name": spec.name,
            "description": spec.description,
            "origin": origin.to_dict(),
            "physics_rate_hz": spec.physics_rate_hz,
            "gravity_mps2": spec.gravity_mps2,
            "air_density_kgm3": spec.air_density_kgm3,
            "terrain": terrain_json,
            "vehicle": {"name": vehicle.name, "urdf": urdf.relative_to(tmp).as_posix(),
                        "spec": json.loads(vehicle.model_dump_json())},
            "spawn": {"enu": list(spawn), "yaw_rad": yaw, "rest": rest},
            "wind": json.loads(spec.wind.model_dump_json()),
            "vine_rows_enu": [[list(p) for p in r] for r in rows],
            "rows_auto": spec.rows == "auto",
            "rows_detection": rows_detection,
            "canopy_width_m": spec.canopy_width_m,
            "canopy": {**canopy.to_dict(), "segments": canopy_doc} if canopy is not None else None,
            "air": spec.air.model_dump(mode="json", exclude_none=True) if spec.air is not None else None,
            "geofence": json.loads(geofence.model_dump_json()) if geofence else None,
            "gis": gis_doc,
            "sdf": "world.sdf",
        }
        write_json(tmp / "world.json", doc)
        with man.stage("sdf"):
            sdf = world_sdf(name=spec.name, origin=origin, rate_hz=spec.physics_rate_hz, gravity=spec.gravity_mps2,
                            wind=spec.wind, terrain=sdf_terrain, vehicle=vehicle, spawn=(*spawn, yaw),
                            canopy=canopy, ground=info.height)
            (tmp / "world.sdf").write_text(sdf, encoding="utf-8")
        man.extra["world"] = {"name": spec.name, "terrain": terrain_json["kind"], "origin": origin.to_dict(),
                              "vehicle": vehicle.name}
    log.info("world %s built in %s", spec.name, out)
    return out


def _canopy_segments(spec: WorldSpec, canopy: Any, grid: TerrainGrid | None, tmp: Path, terrain_json: dict[str, Any],
                     tdir: Path, origin: GeoOrigin) -> dict[str, Any] | None:
    """The rows' canopy segments (:func:`vinecli.world.canopy_build.canopy_segments`) written into the world;
    world.json ``canopy.segments`` (None without rows or spacing)."""
    from vinecli.world.canopy_build import canopy_segments
    from vinecli.world.canopy_files import write_canopy_segments

    assert spec.canopy is not None
    segs = canopy_segments(spec.canopy, canopy, grid.heights if grid is not None else None)
    if segs is None:
        return None
    log.info("canopy segments: %s", segs.summary_line())
    return write_canopy_segments(tmp, segs, terrain_json, tdir, origin)


def _warn_rows_outside(rows: list[Any], bounds: list[float], fence: Any, name: str) -> None:
    """One warning line each when detected rows leave the terrain or the geofence polygon."""
    from shapely.geometry import LineString, Polygon, box

    lines = [LineString(r) for r in rows if len(r) >= 2]
    areas = [("terrain", box(*bounds))]
    if fence is not None and fence.polygon_enu:
        areas.append(("geofence", Polygon(fence.polygon_enu)))
    for what, area in areas:
        out = [ln.length - ln.intersection(area).length for ln in lines]
        n = sum(o > 0.05 for o in out)
        if n:
            log.warning("world %s: %d of %d detected rows leave the %s (up to %.1f m outside); plans clip them",
                        name, n, len(lines), what, max(out))


def _auto_rows(t: Any, base: Path, terrain_json: dict[str, Any], tdir: Path, grid: TerrainGrid | None, name: str,
               fence: Any = None) -> tuple[list[list[list[float]]], dict[str, Any] | None]:
    """``rows: auto``: rows detected on the source DSM (the same rows ``plan rows DSM`` finds, mapped into
    the world through the terrain's CRS frame), or on the height grid for a terrain directory."""
    from vinecli.rows.source import detect_rows_in_dsm, detect_rows_on_grid, dsm_rows_in_frame, terrain_frame

    frame = terrain_frame(terrain_json, tdir)
    if isinstance(t, DsmTerrain) and frame is not None:
        dsm = detect_rows_in_dsm(_resolve(base, t.path))
        det, rows, source = dsm.detection, dsm_rows_in_frame(dsm, frame), "dsm"
    elif grid is not None:
        det = detect_rows_on_grid(grid)
        rows, source = det.rows, "grid"
    else:
        log.warning("world %s: rows: auto on flat terrain: no rows", name)
        return [], None
    log.info("world %s: %s", name, det.summary())
    if det.confidence < 0.5:
        log.warning("world %s: rows: auto found no clear rows (confidence %.2f)", name, det.confidence)
    _warn_rows_outside(rows, terrain_json["bounds_enu"], fence, name)
    info = {k: v for k, v in det.to_dict().items() if k != "rows_enu"}
    info.update(source=source, frame=frame.to_dict() if frame is not None else None)
    return [[list(p) for p in r] for r in rows], info


def _gis(spec: WorldSpec, base: Path, terrain_json: dict[str, Any], tdir: Path, origin: GeoOrigin,
         rows: list[list[tuple[float, float]]]) -> tuple[Any, list[list[tuple[float, float]]], dict[str, Any]]:
    """``gis:``: (geofence, rows cut by the no-spray zones, world.json ``gis``) from the spec's GIS files."""
    from vinecli.gis.georef import world_georef
    from vinecli.specs.mission import GeofenceSpec
    from vinecli.world.gis_inputs import cut_rows, read_world_gis

    assert spec.gis is not None
    g = read_world_gis(spec.gis, base, world_georef(terrain_json, tdir, origin), tuple(terrain_json["bounds_enu"]))
    sources = g.row_sources if g.rows is not None else [{"layer": None, "fid": None, "part": 0} for _ in rows]
    given = g.rows if g.rows is not None else rows
    rows, row_sources = cut_rows(given, sources, g.no_spray)
    if given and not rows:
        zones = g.files["no_spray"]
        raise InputError(f"the {len(g.no_spray)} no-spray zones (buffers included) cover all {len(given)} rows: "
                         f"nothing would be sprayed", path=zones[0]["path"] if len(zones) == 1 else None)
    geofence = spec.geofence
    if g.fence is not None:
        base_fence = spec.geofence or GeofenceSpec()
        geofence = base_fence.model_copy(update={"polygon_enu": [tuple(p) for p in g.fence]})
    doc = {"files": g.files, "row_sources": row_sources, "no_spray_enu": [[list(p) for p in z] for z in g.no_spray]}
    return geofence, rows, doc


#: a rest attitude tilted more than this at the spawn is reported (log warning), deg
MAX_REST_TILT_DEG = 10.0


def _refuse_unsafe(spec_path: Path, allow: bool) -> Callable[[PreflightFailure | None], None]:
    """A function that raises SpecError for a failed spawn preflight check (or only warns when ``allow``)."""
    def unsafe(failure: PreflightFailure | None) -> None:
        if failure is None:
            return
        if allow:
            log.warning("%s (allowed by --allow-unsafe-spawn)", failure.message)
            return
        raise SpecError(f"unsafe spawn: {failure.message}; move the spawn or pass --allow-unsafe-spawn",
                        path=spec_path)
    return unsafe


def _rest_at_spawn(terrain_json: dict[str, Any], tmp: Path, grid: TerrainGrid | None, vehicle: Any, urdf: Path,
                   spawn: Any, spec: WorldSpec) -> dict[str, Any]:
    """Settle the vehicle (full tank) at the world's spawn in PyBullet (``spawn`` its rest position on the height
    grid, m ENU, where the settling starts): its rest pose for world.json ``spawn.rest``."""
    from vinecli.frames import quat_to_euler, tilt_angle
    from vinecli.world.engine import rest_pose

    info = TerrainInfo(kind=terrain_json["kind"], files=[tmp / f for f in terrain_json.get("files", [])],
                       grid=grid, flat_z=float(terrain_json.get("flat_z", 0.0)),
                       offset=tuple(terrain_json.get("offset_enu", (0.0, 0.0, 0.0))))  # type: ignore[arg-type]
    tank = vehicle.tank
    x, y, yaw = spec.spawn.x_m, spec.spawn.y_m, math.radians(spec.spawn.yaw_deg)
    r = rest_pose(info, urdf, x=x, y=y, yaw=yaw, z_guess=spawn[2], collision_box_m=vehicle.frame.collision_box_m,
                  landing_gear_height_m=vehicle.frame.landing_gear_height_m,
                  liquid_kg=vehicle.liquid_mass(tank.capacity_l) if tank is not None else 0.0,
                  mount_flu=tuple(tank.mount_m) if tank is not None else (0.0, 0.0, 0.0),
                  rate_hz=spec.physics_rate_hz, gravity=spec.gravity_mps2)
    roll, pitch, _ = quat_to_euler(r.quat)
    return {"enu": [float(c) for c in r.pos], "tilt_deg": math.degrees(tilt_angle(r.quat)),
            "roll_deg": math.degrees(roll), "pitch_deg": math.degrees(pitch),
            "drift_m": math.hypot(r.pos[0] - x, r.pos[1] - y), "settled": r.settled, "settle_time_s": r.time_s}


def _terrain_sources(t: Any) -> list[Path]:
    """Files or directories the terrain is read from (``--out`` may not equal or contain them)."""
    if isinstance(t, DsmTerrain):
        return [t.path]
    if isinstance(t, FlatTerrain):
        return []
    return [t.dir]


def _terrain(t: Any, tdir: Path, tmp: Path, base: Path, given_origin: GeoOrigin | None, spec_path: Path,
             man: Manifest) -> tuple[dict[str, Any], dict[str, Any], TerrainGrid | None, GeoOrigin]:
    """Convert/copy the terrain into ``tdir``; returns (world.json terrain, SDF terrain, grid, origin)."""
    from vinecli.terrain.heightmap import convert_to_heightmap, load_heightmap
    from vinecli.terrain.tiles import convert_to_tiles, load_tiles
    from vinecli.world.terrain_src import heightmap_grid, origin_offset, tiles_grid

    if isinstance(t, FlatTerrain):
        if given_origin is None:
            raise SpecError("a flat world needs origin: {lat, lon, alt}", path=spec_path)
        h = t.size_m / 2
        tj = {"kind": "flat", "files": [], "grid": None, "bounds_enu": [-h, -h, h, h],
              "z_range_enu": [t.z_m, t.z_m], "flat_z": t.z_m, "source": {"type": "flat"}}
        return tj, {"kind": "flat", "flat_z": t.z_m, "size": t.size_m}, None, given_origin

    if isinstance(t, DsmTerrain):
        src = _resolve(base, t.path)
        source: dict[str, Any] = {"type": "dsm", "dsm": str(src), "format": t.format}
        if t.format == "tiles":
            convert_to_tiles(src, tdir, max_error=t.max_error_m, tile_px=t.tile_px, **t.options)
            source.update(max_error_m=t.max_error_m, tile_px=t.tile_px, options=t.options)
            kind = "tiles"
        else:
            convert_to_heightmap(src, tdir, size=t.size, **t.options)
            source.update(size=t.size, options=t.options)
            kind = "heightmap"
    else:
        src = _resolve(base, t.dir)
        if not src.is_dir():
            raise SpecError(f"terrain directory not found: {src}", path=spec_path)
        shutil.copytree(src, tdir)
        source = {"type": f"{t.type}_dir", "dir": str(src)}
        kind = t.type

    if kind == "heightmap":
        hm = load_heightmap(tdir)
        origin = given_origin or hm.origin
        if origin is None:
            raise SpecError("the heightmap has no geodetic origin (DSM without CRS): give origin:", path=spec_path)
        ox, oy, _oz = origin_offset(hm.origin, origin)
        grid = heightmap_grid(hm.heights, hm.spacing_m, (ox, oy), -origin.alt)
        zmin, zmax = hm.z_min - origin.alt, hm.z_max - origin.alt
        files = [f"terrain/{n}" for n in ("heightmap.png", "heightmap.tif", "heightmap.json")]
        tj = {"kind": "heightmap", "files": files, "heightfield": {"size": hm.size, "spacing_m": hm.spacing_m}}
        sdf = {"kind": "heightmap", "heightmap_png": "terrain/heightmap.png", "size_m": [hm.size_m, hm.size_m],
               "z_min": zmin, "z_max": zmax, "centre": [ox, oy]}
    else:
        ts = load_tiles(tdir)
        origin = given_origin or ts.origin
        if origin is None:
            raise SpecError("the tiles have no geodetic origin (DSM without CRS): give origin:", path=spec_path)
        if ts.origin is None:
            offset = (0.0, 0.0, ts.alt_m - origin.alt)
        else:
            ox, oy, oz = origin_offset(ts.origin, origin)
            offset = (ox, oy, oz + ts.alt_m - ts.origin.alt)
        paths = [tile.path for tile in ts.tiles]
        pix = ts.meta.get("pixel_size_m") or [0.05, 0.05]
        grid = tiles_grid(paths, offset, spacing_m=max(0.05, float(min(pix))))
        rel = [p.relative_to(tmp).as_posix() for p in paths]
        tj = {"kind": "tiles", "files": [*rel, "terrain/tiles.json"], "offset_enu": list(offset)}
        sdf = {"kind": "tiles", "tiles": rel, "offset": list(offset)}
    grid.save(tdir / "grid.npz")
    tj.update({"grid": "terrain/grid.npz", "bounds_enu": list(grid.bounds), "z_range_enu": list(grid.z_range),
               "source": source})
    return tj, sdf, grid, origin
