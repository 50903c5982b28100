"""``vinecli world build``: WorldSpec YAML -> a world directory (see :mod:`vinecli.world.model`).

DIR/world.json, DIR/terrain/ (grid.npz + heightmap or tiles), DIR/vehicles/<name>.urdf,
DIR/world.sdf and DIR/manifest.json, written atomically.
"""

from __future__ import annotations

import json
import logging
import math
import shutil
from pathlib import Path
from typing import Any

from vinecli.errors import SpecError
from vinecli.geo import GeoOrigin
from vinecli.outputs import Manifest, atomic_output_dir, write_json
from vinecli.specs import load_spec
from vinecli.world.grid import TerrainGrid
from vinecli.world.model import SCHEMA, TerrainInfo, rest_position
from vinecli.world.spec import DsmTerrain, FlatTerrain, HeightmapTerrain, TilesTerrain, WorldSpec

__all__ = ["build_world"]

log = logging.getLogger(__name__)


def _resolve(base: Path, p: Path) -> Path:
    return p if p.is_absolute() else (base / p)


def build_world(spec_path: Path | str, out: Path | str, *, overwrite: bool = False) -> Path:
    """Build the world described by ``spec_path`` into ``out``; returns ``out``."""
    from vinecli.vehicle import load_vehicle
    from vinecli.vehicle.urdf import write_urdf
    from vinecli.world import terrain_src as ts
    from vinecli.world.sdf import world_sdf

    spec_path = Path(spec_path)
    out = Path(out)
    spec = load_spec(spec_path, WorldSpec)
    base = spec_path.resolve().parent
    man = Manifest(command="world build", parameters={"spec": str(spec_path), "out": str(out)}, inputs=[spec_path])
    given_origin = GeoOrigin(spec.origin.lat, spec.origin.lon, spec.origin.alt) if spec.origin else None
    veh_arg: str | Path = spec.vehicle
    if spec.vehicle.endswith((".yaml", ".yml")):
        veh_arg = _resolve(base, Path(spec.vehicle))
    vehicle = load_vehicle(veh_arg)

    with atomic_output_dir(out, man, overwrite=overwrite) as tmp:
        tdir = tmp / "terrain"
        tdir.mkdir()
        terrain_json: dict[str, Any]
        sdf_terrain: dict[str, Any]
        grid: TerrainGrid | None
        t = spec.terrain
        with man.stage("terrain"):
            if isinstance(t, FlatTerrain):
                if given_origin is None:
                    raise SpecError("a flat world needs origin: {lat, lon, alt}", path=spec_path)
                origin = given_origin
                grid = None
                h = t.size_m / 2
                terrain_json = {"kind": "flat", "files": [], "grid": None, "bounds_enu": [-h, -h, h, h],
                                "z_range_enu": [t.z_m, t.z_m], "flat_z": t.z_m, "source": {"type": "flat"}}
                sdf_terrain = {"kind": "flat", "flat_z": t.z_m, "size": t.size_m}
            else:
                if isinstance(t, DsmTerrain):
                    src = _resolve(base, t.path)
                    man.inputs.append(src)
                    dsm = ts.read_dsm(src, resolution_m=t.resolution_m, origin=given_origin)
                    origin, full = dsm.origin, dsm.grid
                    source: dict[str, Any] = {"type": "dsm", **dsm.info, "format": t.format}
                    fmt = t.format
                elif isinstance(t, HeightmapTerrain):
                    src = _resolve(base, t.dir)
                    full, origin, files = ts.read_heightmap_dir(src, given_origin)
                    source = {"type": "heightmap_dir", "dir": str(src)}
                    fmt = "heightmap"
                elif isinstance(t, TilesTerrain):
                    src = _resolve(base, t.dir)
                    full, origin, files = ts.read_tiles_dir(src, given_origin)
                    source = {"type": "tiles_dir", "dir": str(src)}
                    fmt = "tiles"
                else:  # pragma: no cover - closed union
                    raise SpecError(f"unknown terrain type {type(t).__name__}", path=spec_path)
                if fmt == "heightmap":
                    size = t.size if isinstance(t, DsmTerrain) else full.nx
                    grid = ts.square_heightmap(full, size) if isinstance(t, DsmTerrain) else full
                    written = ts.write_heightmap(grid, tdir, origin)
                    zmin, zmax = grid.z_range
                    xmin, ymin, xmax, ymax = grid.bounds
                    terrain_json = {"kind": "heightmap", "files": [f"terrain/{p.name}" for p in written],
                                    "heightfield": {"size": grid.nx, "spacing_m": grid.dx}}
                    sdf_terrain = {"kind": "heightmap", "heightmap_png": "terrain/heightmap.png",
                                   "size_m": [xmax - xmin, ymax - ymin], "z_min": zmin, "z_max": zmax,
                                   "centre": [(xmin + xmax) / 2, (ymin + ymax) / 2]}
                else:
                    grid = full
                    if isinstance(t, DsmTerrain):
                        tiles = ts.write_tiles(full, tdir / "tiles", max_error_m=t.max_error_m, tile_px=t.tile_px)
                        source["max_error_m"] = t.max_error_m
                    else:
                        (tdir / "tiles").mkdir()
                        tiles = []
                        for f in files:
                            dst = tdir / "tiles" / f.name
                            shutil.copy2(f, dst)
                            tiles.append(dst)
                    rel = [p.relative_to(tmp).as_posix() for p in tiles]
                    terrain_json = {"kind": "tiles", "files": rel}
                    sdf_terrain = {"kind": "tiles", "tiles": rel}
                grid.save(tdir / "grid.npz")
                terrain_json.update({"grid": "terrain/grid.npz", "bounds_enu": list(grid.bounds),
                                     "z_range_enu": list(grid.z_range), "source": source})

        info = TerrainInfo(kind=terrain_json["kind"], grid=grid, flat_z=float(terrain_json.get("flat_z", 0.0)))
        xmin, ymin, xmax, ymax = terrain_json["bounds_enu"]
        sx, sy = spec.spawn.x_m, spec.spawn.y_m
        if not (xmin <= sx <= xmax and ymin <= sy <= ymax):
            raise SpecError(f"spawn ({sx}, {sy}) is outside the terrain {terrain_json['bounds_enu']}", path=spec_path)
        spawn = rest_position(info, vehicle, sx, sy)
        yaw = math.radians(spec.spawn.yaw_deg)

        with man.stage("vehicle"):
            urdf = write_urdf(vehicle, tmp / "vehicles" / f"{vehicle.name}.urdf")
            (tmp / "vehicles" / f"{vehicle.name}.json").write_text(vehicle.model_dump_json(indent=1))

        rows = [] if spec.rows in (None, "auto") else [[list(p) for p in row] for row in spec.rows]
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
            "spawn": {"enu": list(spawn), "yaw_rad": yaw},
            "wind": json.loads(spec.wind.model_dump_json()),
            "vine_rows_enu": rows,
            "rows_auto": spec.rows == "auto",
            "geofence": json.loads(spec.geofence.model_dump_json()) if spec.geofence else None,
            "sdf": "world.sdf",
        }
        write_json(tmp / "world.json", doc)
        with man.stage("sdf"):
            sdf = world_sdf(name=spec.name, origin=origin, rate_hz=spec.physics_rate_hz, gravity=spec.gravity_mps2,
                            wind=spec.wind, terrain=sdf_terrain, vehicle=vehicle, spawn=(*spawn, yaw))
            (tmp / "world.sdf").write_text(sdf, encoding="utf-8")
        man.extra["world"] = {"name": spec.name, "terrain": terrain_json["kind"], "origin": origin.to_dict(),
                              "vehicle": vehicle.name}
    log.info("world %s built in %s", spec.name, out)
    return out
