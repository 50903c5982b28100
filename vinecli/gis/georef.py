"""Where a local frame sits on the Earth: local metres (x east, y north) <-> WGS84 longitude/latitude.

A frame backed by a CRS (a DSM's or a DSM world's, :class:`~vinecli.rows.source.RowFrame`) goes through
that CRS, so features land on the raster exactly where a GIS shows them; a frame without one (a flat world,
a raster without CRS but with a given origin) is the topocentric ENU frame of its
:class:`~vinecli.geo.GeoOrigin`.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vinecli.geo import GeoFrame, GeoOrigin
from vinecli.rows.source import RowFrame, terrain_frame

__all__ = ["Georef", "geo_frame", "world_geo_origin", "world_georef", "world_dir_georef"]

Points = list[tuple[float, float]]


@dataclass(frozen=True)
class Georef:
    """Local metres <-> WGS84 (lon, lat) and any CRS: through ``frame``'s CRS when it has one, else the
    topocentric ENU frame of ``origin``."""

    frame: RowFrame | None = None
    origin: GeoOrigin | None = None

    def __post_init__(self) -> None:
        if (self.frame is None or self.frame.crs is None) and self.origin is None:
            raise ValueError("a Georef needs a frame with a CRS or a geodetic origin")

    @property
    def crs(self) -> str:
        """The CRS local coordinates go through (``EPSG:4326`` for the topocentric frame)."""
        return self.frame.crs if self.frame is not None and self.frame.crs is not None else "EPSG:4326"

    def _transformer(self, src: Any, dst: Any) -> Any:
        return _transformer(str(src), str(dst))

    def to_crs(self, pts: Points, crs: Any) -> Points:
        """Local metres -> coordinates in ``crs`` (x/lon first)."""
        if self.frame is not None and self.frame.crs is not None:
            xy = self.frame.to_crs(pts)
            tr = self._transformer(self.frame.crs, crs)
            return [tuple(map(float, tr.transform(x, y))) for x, y in xy]  # type: ignore[misc]
        assert self.origin is not None
        lonlat = []
        for x, y in pts:
            lat, lon, _ = self.origin.enu_to_geodetic(x, y, 0.0)
            lonlat.append((lon, lat))
        if str(crs).upper() in ("EPSG:4326", "OGC:CRS84"):
            return lonlat
        tr = self._transformer("EPSG:4326", crs)
        return [tuple(map(float, tr.transform(lo, la))) for lo, la in lonlat]  # type: ignore[misc]

    def from_crs(self, pts: Points, crs: Any) -> Points:
        """Coordinates in ``crs`` (x/lon first) -> local metres."""
        if self.frame is not None and self.frame.crs is not None:
            tr = self._transformer(crs, self.frame.crs)
            return self.frame.from_crs([tuple(map(float, tr.transform(x, y))) for x, y in pts])  # type: ignore[misc]
        assert self.origin is not None
        tr = self._transformer(crs, "EPSG:4326")
        out = []
        for a, b in pts:
            lon, lat = tr.transform(a, b)
            e, n, _ = self.origin.geodetic_to_enu(float(lat), float(lon), self.origin.alt)
            out.append((e, n))
        return out

    def to_lonlat(self, pts: Points) -> Points:
        """Local metres -> WGS84 (lon, lat) degrees."""
        return self.to_crs(pts, "EPSG:4326")

    def from_lonlat(self, pts: Points) -> Points:
        """WGS84 (lon, lat) degrees -> local metres."""
        return self.from_crs(pts, "EPSG:4326")


@functools.lru_cache(maxsize=32)
def _transformer(src: str, dst: str) -> Any:
    """The pyproj transformer between the horizontal parts of two CRSs (x/lon first), made once per pair: a
    writer converts every feature through it."""
    from pyproj import CRS, Transformer

    def horizontal(c: str) -> Any:
        pc = CRS.from_user_input(c)
        return pc.sub_crs_list[0] if pc.is_compound else pc

    return Transformer.from_crs(horizontal(src), horizontal(dst), always_xy=True)


def geo_frame(frame: RowFrame | None, origin: GeoOrigin) -> GeoOrigin:
    """The world's georeference for everything that is not a GIS file (the ``.plan``, GNSS, the firmware's home
    and mission, the deposition GeoTIFF): a :class:`~vinecli.geo.GeoFrame` through ``frame``'s CRS (the same map as
    :class:`Georef`), else ``origin`` itself (its topocentric frame)."""
    if frame is None or frame.crs is None:
        return origin
    return GeoFrame(origin.lat, origin.lon, origin.alt, crs=frame.crs, crs_centre=frame.centre,
                    m_per_unit=frame.scale, offset=frame.offset)


def world_geo_origin(terrain: dict[str, Any], terrain_dir: Path, origin: GeoOrigin) -> GeoOrigin:
    """:func:`geo_frame` of a world (world.json ``terrain`` and the terrain directory, its recorded ``origin``)."""
    return geo_frame(terrain_frame(terrain, terrain_dir), origin)


def world_georef(terrain: dict[str, Any], terrain_dir: Path, origin: GeoOrigin) -> Georef:
    """The georeference of a world: its terrain's CRS frame (world.json ``terrain`` and the terrain directory;
    a world built from a DSM with a CRS), else the topocentric frame of its geodetic ``origin``."""
    frame = terrain_frame(terrain, terrain_dir)
    return Georef(frame if frame is not None and frame.crs is not None else None, origin)


def world_dir_georef(world_dir: Path | str) -> Georef:
    """:func:`world_georef` of a built world directory."""
    root = Path(world_dir)
    doc = json.loads((root / "world.json").read_text(encoding="utf-8"))
    return world_georef(doc["terrain"], root / "terrain", GeoOrigin.from_dict(doc["origin"]))
