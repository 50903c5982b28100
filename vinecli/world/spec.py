"""World specification (``worlds/*.yaml``), validated with pydantic.

Paths inside the file are relative to the file. Frames: world ENU (m) about the geodetic
origin; yaw in degrees from east, counter-clockwise (ENU convention).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, model_validator

from vinecli.constants import STANDARD_GRAVITY
from vinecli.names import SafeName
from vinecli.specs import StrictModel
from vinecli.specs.canopy import AirSpec, CanopySpec
from vinecli.specs.limits import (
    MAX_DISTANCE_M,
    MAX_ORIGIN_ALT_M,
    MAX_ROW_VERTICES,
    MIN_ORIGIN_ALT_M,
    Coord,
    Vec2Coord,
    over_limit,
)
from vinecli.specs.mission import GeofenceSpec
from vinecli.specs.vehicle import DEFAULT_VEHICLE
from vinecli.specs.wind import WindSpec
from vinecli.terrain.defaults import MIN_TILE_PX

__all__ = [
    "DsmTerrain",
    "FlatTerrain",
    "GisLayerSpec",
    "GisZoneSpec",
    "HeightmapTerrain",
    "OriginSpec",
    "SpawnSpec",
    "TilesTerrain",
    "WorldGisSpec",
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
    tile_px: int = Field(256, ge=MIN_TILE_PX, description="tiles: tile step in raster pixels (tiles share borders)")
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
    alt: float = Field(0.0, ge=MIN_ORIGIN_ALT_M, le=MAX_ORIGIN_ALT_M, description="m above mean sea level")


class SpawnSpec(StrictModel):
    """Where the vehicle starts: x, y (m ENU); z is placed on the terrain surface."""

    x_m: Coord = 0.0
    y_m: Coord = 0.0
    yaw_deg: float = Field(0.0, description="ENU yaw, deg from east, CCW")


class GisLayerSpec(StrictModel):
    """A layer of a GIS file: GeoJSON, Shapefile, GeoPackage or KML/KMZ in any CRS (path relative to this file;
    ``layer``: default the file's first layer)."""

    path: Path
    layer: str | None = None


class GisZoneSpec(GisLayerSpec):
    """No-spray or buffer zones: polygons grown by ``buffer_m`` (a feature's own ``buffer_m`` property wins)."""

    buffer_m: float = Field(0.0, ge=0, le=MAX_DISTANCE_M, description="distance the zone is grown by, m")


class WorldGisSpec(StrictModel):
    """What the grower already has as GIS files: the rows (lines), the field boundary or fence (one polygon: the
    world's geofence) and no-spray / buffer zones (polygons the sprayer stays off in: rows are cut there)."""

    rows: GisLayerSpec | None = None
    fence: GisLayerSpec | None = None
    no_spray: list[GisZoneSpec] = Field(default_factory=list)


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
    gis: WorldGisSpec | None = Field(None, description="rows, fence and no-spray zones from GIS files")
    canopy: CanopySpec | None = Field(None, description="hedges along the rows (spray budget: interception); none: bare rows")
    air: AirSpec | None = Field(None, description="temperature and humidity (drop evaporation); none: no evaporation")

    @model_validator(mode="after")
    def _one_source_each(self) -> WorldSpec:
        if self.gis is not None and self.gis.rows is not None and self.rows is not None:
            raise ValueError("rows given twice: 'rows' and 'gis.rows'")
        if self.gis is not None and self.gis.fence is not None and self.geofence is not None \
                and self.geofence.polygon_enu is not None:
            raise ValueError("fence given twice: 'geofence.polygon_enu' and 'gis.fence'")
        if isinstance(self.rows, list):
            problem = over_limit("row vertices", sum(len(r) for r in self.rows), MAX_ROW_VERTICES, "simplify the rows")
            if problem:
                raise ValueError(problem)
        return self
