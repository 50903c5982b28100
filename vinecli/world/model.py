"""The built world as the simulation sees it (:func:`load_world`), read from ``DIR/world.json``.

``world.json`` (schema ``vinecli.world/1``), every path relative to DIR::

    {"schema": "vinecli.world/1", "name", "description",
     "origin": {"lat", "lon", "alt"},                    # deg WGS84, m
     "physics_rate_hz", "gravity_mps2", "air_density_kgm3",
     "terrain": {"kind": "flat"|"heightmap"|"tiles",
                 "files": [...],                         # heightmap: heightmap png/tif/json; tiles: OBJ files
                 "grid": "terrain/grid.npz" | null,      # height grid (ENU) for lookups and the heightfield
                 "bounds_enu": [xmin, ymin, xmax, ymax], "z_range_enu": [zmin, zmax],
                 "flat_z": float,                        # flat only
                 "offset_enu": [x, y, z],                # tiles: where the meshes' local origin is
                 "heightfield": {"size": N, "spacing_m": d}  # heightmap only: the grid is N×N
                 "source": {...}},                       # how the terrain was made
     "vehicle": {"name", "urdf": "vehicles/<name>.urdf", "spec": {VehicleSpec as JSON}},
     "spawn": {"enu": [x, y, z], "yaw_rad",             # vehicle CoM placed on the terrain (level)
               "rest": {"enu", "tilt_deg", "roll_deg", "pitch_deg", "drift_m", "settled", "settle_time_s"}},
                                                         # where it comes to rest in PyBullet (full tank); world
                                                         # build warns when tilt_deg > 10 (not a take-off spot)
     "wind": {WindSpec as JSON},
     "vine_rows_enu": [[[x, y], ...], ...], "rows_auto": bool,
     "rows_detection": {"count", "direction_deg", "spacing_m", "strength", "confidence", "lengths_m", "support",
                        "source": "dsm"|"grid", "frame": {"crs", "centre_crs", "m_per_crs_unit", "offset_enu"}}
                       | null,                           # rows: auto: how vine_rows_enu were detected (at build)
     "geofence": {GeofenceSpec as JSON} | null,
     "gis": {"files": {...}, "row_sources": [{"row", "layer", "fid", "part"}], "no_spray_enu": [[[x, y], ...]]}
            | null,                                      # gis: in the spec (vinecli.world.gis_inputs)
     "canopy_width_m": float,                            # row band width of the spray metrics, m
     "canopy": {"source", "bbch", "profile", "g_factor", "leaf_width_m", "spacing_m", "lai", "notes",
                "hedges": [{"row", "base_m", "top_m", "width_m", "lad_m2m3"}],
                "segments": {"files", <CanopySegments.summary()>} | null} | null,
                                                         # each row's hedge (vinecli.spray.canopy, docs/budget.md),
                                                         # its segments (vinecli.world.canopy_files, docs/dose.md)
     "air": {"temperature_c", "relative_humidity_pct", "obukhov_length_m"} | null,   # drop evaporation, stability
     "sdf": "world.sdf"}
"""

from __future__ import annotations

import dataclasses
import json
import math
import threading
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from pydantic import ValidationError

from vinecli.constants import STANDARD_GRAVITY
from vinecli.errors import InputError, SpecError
from vinecli.frames import Vec3
from vinecli.geo import GeoOrigin
from vinecli.gis.georef import world_geo_origin
from vinecli.inputs import note_input, read_input_text
from vinecli.specs import format_validation_error
from vinecli.specs.mission import GeofenceSpec
from vinecli.specs.vehicle import VehicleSpec
from vinecli.specs.wind import WindSpec
from vinecli.terrain.grid import TerrainGrid

__all__ = ["SCHEMA", "TerrainInfo", "World", "keep_loaded_worlds", "load_world", "rest_position"]

SCHEMA = "vinecli.world/1"


@dataclass
class TerrainInfo:
    """Terrain of a built world. ``files`` are absolute paths; heights ENU (m)."""

    kind: Literal["heightmap", "tiles", "flat"]
    files: list[Path] = field(default_factory=list)
    bounds: tuple[float, float, float, float] = (-100.0, -100.0, 100.0, 100.0)  # xmin, ymin, xmax, ymax
    z_range: tuple[float, float] = (0.0, 0.0)
    grid: TerrainGrid | None = None
    flat_z: float = 0.0
    offset: Vec3 = (0.0, 0.0, 0.0)  # tiles: position of the meshes' local origin in the world (m ENU)

    def height(self, x: float, y: float) -> float:
        """Terrain z (m, ENU) at (x, y)."""
        g = self.grid
        return self.flat_z if g is None else g.height(x, y)


@dataclass
class World:
    """Everything a run needs (docs/architecture.md "World"). Positions ENU m, angles rad."""

    name: str
    dir: Path
    origin: GeoOrigin
    terrain: TerrainInfo
    vehicle: VehicleSpec
    urdf: Path
    spawn_enu: Vec3  # vehicle CoM at rest on the terrain
    spawn_yaw_rad: float = 0.0
    wind: WindSpec = field(default_factory=WindSpec)
    physics_rate_hz: float = 250.0
    gravity: float = STANDARD_GRAVITY  # m/s², positive
    air_density: float = 1.225  # kg/m³
    vine_rows_enu: list[list[tuple[float, float]]] = field(default_factory=list)
    geofence: GeofenceSpec | None = None
    rows_auto: bool = False
    description: str = ""
    rows_detection: dict[str, Any] | None = None  # rows: auto: detection figures (see world.json)
    canopy_width_m: float = 0.6  # m, row band width for the spray metrics
    canopy: dict[str, Any] | None = None  # world.json "canopy": each row's hedge (canopy_model())
    air: tuple[float, float] | None = None  # temperature °C, relative humidity % (drop evaporation)
    obukhov_m: float = math.inf  # Obukhov length of the surface layer (far-field drift), m; inf: neutral
    #: the grower's no-spray zones (world.json gis.no_spray_enu: rings grown by their buffer), ENU m
    no_spray_enu: list[list[tuple[float, float]]] = field(default_factory=list)

    def __post_init__(self) -> None:
        # bind the fast lookup directly (no extra call layer in the 250 Hz loop)
        g = self.terrain.grid
        if g is not None:
            self.terrain_height = g.height  # type: ignore[method-assign]

    def terrain_height(self, x: float, y: float) -> float:
        """Terrain z (m, ENU) at (x, y): bilinear on the height grid (flat: the plane's z)."""
        return self.terrain.flat_z

    def canopy_model(self) -> Any:
        """The rows' hedges (:class:`vinecli.spray.canopy.Canopy`), or None when the world has no canopy."""
        if not self.canopy:
            return None
        from vinecli.spray.canopy import Canopy

        return Canopy.from_dict(self.canopy, self.vine_rows_enu)

    def terrain_preview(self, max_side: int = 129) -> dict[str, Any]:
        """``x`` (nx,), ``y`` (ny,), ``z`` (ny, nx) for plots (≤ max_side per side)."""
        import numpy as np

        g = self.terrain.grid
        if g is not None:
            return g.preview(max_side)
        xmin, ymin, xmax, ymax = self.terrain.bounds
        x = np.linspace(xmin, xmax, 33)
        y = np.linspace(ymin, ymax, 33)
        return {"x": x, "y": y, "z": np.full((33, 33), self.terrain.flat_z, np.float32)}


class _KeptWorld(threading.local):
    """The last world :func:`load_world` read in this thread, while :func:`keep_loaded_worlds` is on."""

    def __init__(self) -> None:
        self.enabled = False
        self.key: tuple[object, ...] | None = None
        self.world: World | None = None


_KEPT_WORLD = _KeptWorld()


def keep_loaded_worlds(enabled: bool = True) -> None:
    """Keep the last world :func:`load_world` read in this thread, and hand out copies of it while its files are
    unchanged: a batch worker's next case on the same world skips validating its vehicle and wind, reading its
    height grid and its georeference. A copy: a World's own fields may be replaced; what they hold (the height
    grid, the frozen specs, the row lists) is shared and read only, as runs use it."""
    _KEPT_WORLD.enabled = enabled
    if not enabled:
        _KEPT_WORLD.key, _KEPT_WORLD.world = None, None


def _files_key(root: Path, text: str) -> tuple[object, ...]:
    """What makes a world the same one: its folder, world.json's text and the size and mtime of every other file
    in it (a rebuilt or edited world reads again)."""
    stats = tuple((str(p), st.st_size, st.st_mtime_ns) for p in sorted(root.rglob("*"))
                  if p.name != "world.json" and p.is_file() and (st := p.stat()))
    return (str(root.resolve()), text, stats)


def load_world(dir: Path | str) -> World:  # noqa: A002 - the contract's name
    """Read ``DIR/world.json`` (written by :func:`vinecli.world.build_world`); with :func:`keep_loaded_worlds` on,
    a copy of the world this thread read last when its files are unchanged."""
    root = Path(dir)
    wj = root / "world.json"
    if not wj.exists():
        raise SpecError("not a built world (no world.json; run `vinecli world build`)", path=root)
    note_input(root, "world")
    try:
        text = read_input_text(wj, "world.json")
        d = json.loads(text)
    except InputError as exc:
        raise SpecError(exc.problem, path=wj) from None
    except json.JSONDecodeError as exc:
        raise SpecError(f"cannot read world.json: {exc}", path=wj) from None
    except RecursionError:
        raise SpecError("world.json is nested too deeply to be a world (invalid JSON)", path=wj) from None
    if not isinstance(d, dict):
        raise SpecError(f"corrupt world.json: expected a mapping, got {type(d).__name__}", path=wj)
    if d.get("schema") != SCHEMA:
        raise SpecError(f"unsupported world schema {d.get('schema')!r} (expected {SCHEMA})", path=wj)
    key = _files_key(root, text) if _KEPT_WORLD.enabled else None
    if key is not None and key == _KEPT_WORLD.key and _KEPT_WORLD.world is not None:
        return dataclasses.replace(_KEPT_WORLD.world)
    try:
        world = _parse_world(root, wj, d)
        if key is not None:
            _KEPT_WORLD.key, _KEPT_WORLD.world = key, world
            return dataclasses.replace(world)
        return world
    except ValidationError as exc:
        raise SpecError(format_validation_error(exc), path=wj) from None
    except KeyError as exc:
        raise SpecError(f"missing key {exc}", path=wj) from None
    except (TypeError, ValueError, IndexError, AttributeError) as exc:  # a list where a mapping belongs...
        raise SpecError(f"corrupt world.json ({type(exc).__name__}: {exc})", path=wj) from None
    except (OSError, EOFError, zipfile.BadZipFile) as exc:  # a truncated grid.npz
        raise SpecError(f"cannot read the terrain grid ({type(exc).__name__})", path=wj) from None


def _inside(root: Path, rel: str, wj: Path) -> Path:
    """``root/rel``, refused (SpecError) when it leaves the world folder (``..``, an absolute path, a link)."""
    p = root / str(rel)
    if not p.resolve().is_relative_to(root.resolve()):
        raise SpecError(f"a world file lies outside the world folder: {rel!r}", path=wj)
    return p


def _parse_world(root: Path, wj: Path, d: dict[str, Any]) -> World:
    vehicle = VehicleSpec.model_validate(d["vehicle"]["spec"])
    wind = WindSpec.model_validate(d.get("wind") or {})
    geofence = GeofenceSpec.model_validate(d["geofence"]) if d.get("geofence") else None
    t = d["terrain"]
    files = [_inside(root, f, wj) for f in t.get("files", [])]
    for f in files:
        if not f.is_file():
            raise SpecError(f"terrain file missing: {f.relative_to(root)}", path=wj)
    grid = TerrainGrid.load(_inside(root, t["grid"], wj)) if t.get("grid") else None
    terrain = TerrainInfo(
        kind=t["kind"],
        files=files,
        bounds=tuple(float(c) for c in t["bounds_enu"]),  # type: ignore[arg-type]
        z_range=tuple(float(c) for c in t["z_range_enu"]),  # type: ignore[arg-type]
        grid=grid,
        flat_z=float(t.get("flat_z", 0.0)),
        offset=tuple(float(c) for c in t.get("offset_enu", (0.0, 0.0, 0.0))),  # type: ignore[arg-type]
    )
    urdf = _inside(root, d["vehicle"]["urdf"], wj)
    if not urdf.is_file():
        raise SpecError(f"vehicle URDF missing: {d['vehicle']['urdf']}", path=wj)
    return World(
        name=str(d["name"]),
        dir=root.resolve(),
        origin=world_geo_origin(t, root / "terrain", GeoOrigin.from_dict(d["origin"])),
        terrain=terrain,
        vehicle=vehicle,
        urdf=urdf.resolve(),
        spawn_enu=tuple(float(c) for c in d["spawn"]["enu"]),  # type: ignore[arg-type]
        spawn_yaw_rad=float(d["spawn"].get("yaw_rad", 0.0)),
        wind=wind,
        physics_rate_hz=float(d.get("physics_rate_hz", 250.0)),
        gravity=float(d.get("gravity_mps2", STANDARD_GRAVITY)),
        air_density=float(d.get("air_density_kgm3", 1.225)),
        vine_rows_enu=[[(float(p[0]), float(p[1])) for p in row] for row in d.get("vine_rows_enu", [])],
        geofence=geofence,
        rows_auto=bool(d.get("rows_auto", False)),
        rows_detection=d.get("rows_detection"),
        description=str(d.get("description", "")),
        canopy_width_m=float(d.get("canopy_width_m", 0.6)),
        canopy=d.get("canopy"),
        air=(float(d["air"]["temperature_c"]), float(d["air"]["relative_humidity_pct"])) if d.get("air") else None,
        obukhov_m=float((d.get("air") or {}).get("obukhov_length_m") or math.inf),
        no_spray_enu=[[(float(p[0]), float(p[1])) for p in z] for z in (d.get("gis") or {}).get("no_spray_enu") or []],
    )


#: clearance added when placing a vehicle on the terrain, m (it settles within a few steps)
SPAWN_CLEARANCE_M = 0.002


def rest_position(terrain: TerrainInfo, vehicle: VehicleSpec, x: float, y: float) -> Vec3:
    """CoM position (m ENU) of ``vehicle`` resting on the terrain at (x, y).

    z = highest terrain under the collision box footprint (any yaw) + landing-gear height +
    a 2 mm clearance.
    """
    bx, by, _bz = vehicle.frame.collision_box_m
    r = 0.5 * (bx * bx + by * by) ** 0.5
    g = terrain.grid
    ground = terrain.flat_z if g is None else g.max_in_box(x - r, y - r, x + r, y + r)
    return (float(x), float(y), ground + vehicle.frame.landing_gear_height_m + SPAWN_CLEARANCE_M)
