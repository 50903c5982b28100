"""World specification (``worlds/*.yaml``), validated with pydantic.

Paths inside the file are relative to the file. Frames: world ENU (m) about the geodetic
origin; yaw in degrees from east, counter-clockwise (ENU convention).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field

from vinecli.constants import STANDARD_GRAVITY
from vinecli.names import SafeName
from vinecli.specs import StrictModel
from vinecli.specs.canopy import AirSpec, CanopySpec
from vinecli.specs.limits import MAX_DISTANCE_M, Coord, Vec2Coord
from vinecli.specs.mission import GeofenceSpec
from vinecli.specs.vehicle import DEFAULT_VEHICLE
from vinecli.specs.wind import WindSpec

__all__ = [
    "DsmTerrain",
    "FlatTerrain",
    "HeightmapTerrain",
    "OriginSpec",
    "SpawnSpec",
    "TilesTerrain",
    "WorldSpec",
]

Vec2L = Vec2Coord


class FlatTerrain(StrictModel):
    """Flat ground at ``z_m`` (an infinite plane for physics; ``size_m`` for Gazebo and plots)."""

    type: Literal["flat"] = "flat"
    z_m: float = Field(0.0, description="ground height, m ENU")
    size_m: float = Field(200.0, gt=0, le=MAX_DISTANCE_M, description="side of the square ground shown in Gazebo/plots, m")


class HeightmapTerrain(StrictModel):
    """A heightmap directory written by ``vinecli terrain convert --format heightmap``."""

    type: Literal["heightmap"] = "heightmap"
    dir: Path


class TilesTerrain(StrictModel):
    """A mesh-tiles directory written by ``vinecli terrain convert --format tiles``."""

    type: Literal["tiles"] = "tiles"
    dir: Path


class DsmTerrain(StrictModel):
    """A DSM GeoTIFF converted while the world is built (``vinecli terrain convert`` with these options)."""

    type: Literal["dsm"] = "dsm"
    path: Path
    format: Literal["tiles", "heightmap"] = Field("tiles", description="what to convert the DSM into")
    max_error_m: float = Field(0.03, gt=0, description="tiles: maximum vertical error of the triangulation, m")
    tile_px: int = Field(256, ge=2, description="tiles: tile step in raster pixels (tiles share borders)")
    size: int | None = Field(513, ge=3, description="heightmap: side in samples (2^n + 1); None = suggested")
    options: dict[str, Any] = Field(
        default_factory=dict,
        description="more converter options: tiles: fmt, fill, z_unit, max_triangles; heightmap: method, window, "
        "bbox, fill, z_unit",
    )


Terrain = Annotated[FlatTerrain | HeightmapTerrain | TilesTerrain | DsmTerrain, Field(discriminator="type")]


class OriginSpec(StrictModel):
    """Geodetic origin of the ENU frame (WGS84 degrees, metres)."""

    lat: float = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)
    alt: Coord = 0.0


class SpawnSpec(StrictModel):
    """Where the vehicle starts: x, y (m ENU); z is placed on the terrain surface."""

    x_m: Coord = 0.0
    y_m: Coord = 0.0
    yaw_deg: float = Field(0.0, description="ENU yaw, deg from east, CCW")


class WorldSpec(StrictModel):
    """A simulation world: terrain, origin, vehicle and spawn, wind, physics constants, rows, geofence."""

    name: SafeName
    description: str = ""
    terrain: Terrain = FlatTerrain()
    origin: OriginSpec | None = Field(None, description="default: from the terrain's sidecar")
    vehicle: str = Field(DEFAULT_VEHICLE, description="vehicle name (vehicles/<name>.yaml) or path")
    spawn: SpawnSpec = SpawnSpec()
    wind: WindSpec = WindSpec()
    physics_rate_hz: float = Field(250.0, gt=0, le=10000)
    gravity_mps2: float = Field(STANDARD_GRAVITY, gt=0, le=100.0)
    air_density_kgm3: float = Field(1.225, gt=0, le=100.0)
    canopy_width_m: float = Field(0.6, gt=0, le=10.0, description="width of the vine canopy band along each row, m (spray metrics)")
    rows: list[list[Vec2L]] | Literal["auto"] | None = Field(
        None, description="vine rows as ENU polylines [[x, y], ...], or 'auto' (detected by the missions tools)"
    )
    geofence: GeofenceSpec | None = None
    canopy: CanopySpec | None = Field(None, description="hedges along the rows (spray budget: interception); none: bare rows")
    air: AirSpec | None = Field(None, description="temperature and humidity (drop evaporation); none: no evaporation")
