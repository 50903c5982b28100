"""Features in a local frame -> RFC 7946 GeoJSON (WGS84 longitude/latitude, no ``crs`` member) or a
GeoPackage (EPSG:4326), through a :class:`~vinecli.gis.georef.Georef`. Coordinates are rounded to 1e-9
degree (0.1 mm)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vinecli.gis.georef import Georef
from vinecli.outputs import atomic_file, write_text_atomic

__all__ = ["LocalFeature", "feature_collection", "rows_features", "write_features", "write_layers"]


@dataclass
class LocalFeature:
    """One feature in local metres: ``kind`` "LineString" | "Polygon" | "Point", ``coords`` [(x, y)] (a polygon's
    exterior ring, not closed), ``properties``, a polygon's ``holes`` (rings, not closed)."""

    kind: str
    coords: list[tuple[float, float]]
    properties: dict[str, Any] = field(default_factory=dict)
    holes: list[list[tuple[float, float]]] = field(default_factory=list)


def rows_features(rows: list[list[tuple[float, float]]]) -> list[LocalFeature]:
    """One LineString per row, properties ``index`` (0-based, the plan's numbering) and ``length_m``."""
    from vinecli.geometry import polyline_length

    return [LocalFeature("LineString", list(r), {"index": i, "length_m": round(polyline_length(r), 3)})
            for i, r in enumerate(rows)]


def _lonlat(coords: list[tuple[float, float]], georef: Georef) -> list[list[float]]:
    return [[round(lon, 9), round(lat, 9)] for lon, lat in georef.to_lonlat(coords)]


def _geometry(f: LocalFeature, georef: Georef) -> dict[str, Any]:
    ll = _lonlat(f.coords, georef)
    if f.kind == "Polygon":
        rings = [ll, *(_lonlat(h, georef) for h in f.holes)]
        return {"type": "Polygon", "coordinates": [r + [r[0]] for r in rings]}
    if f.kind == "Point":
        return {"type": "Point", "coordinates": ll[0]}
    return {"type": "LineString", "coordinates": ll}


def feature_collection(features: list[LocalFeature], georef: Georef, name: str | None = None) -> dict[str, Any]:
    """An RFC 7946 FeatureCollection (WGS84 lon/lat) of ``features``."""
    out: dict[str, Any] = {"type": "FeatureCollection"}
    if name:
        out["name"] = name
    out["features"] = [{"type": "Feature", "id": i + 1, "properties": f.properties, "geometry": _geometry(f, georef)}
                       for i, f in enumerate(features)]
    return out


def write_features(path: Path | str, features: list[LocalFeature], georef: Georef, *, layer: str = "features") -> Path:
    """Write ``features`` to ``path``: ``.geojson``/``.json`` RFC 7946, ``.gpkg`` a GeoPackage layer ``layer``
    (EPSG:4326); atomically (temporary file, then rename)."""
    path = Path(path)
    fc = feature_collection(features, georef, layer)
    if path.suffix.lower() == ".gpkg":
        _write_gpkg(path, fc, layer)
    else:
        write_text_atomic(path, json.dumps(fc) + "\n")
    return path


def write_layers(path: Path | str, layers: dict[str, list[LocalFeature]], georef: Georef, *,
                 spatial_index: bool = True) -> Path:
    """Write several layers to ``path``: ``.gpkg`` one GeoPackage layer each (EPSG:4326; empty layers left out),
    ``.geojson``/``.json`` one RFC 7946 FeatureCollection whose features carry their layer name in the
    ``layer`` property (GeoJSON has no layers; QGIS splits it by geometry type and filters by property).
    Atomically: a temporary file, then rename. ``spatial_index``: give each GeoPackage layer its R-tree (a few
    hundred points need none; building it is most of writing them)."""
    path = Path(path)
    if path.suffix.lower() != ".gpkg":
        feats = [LocalFeature(f.kind, f.coords, {"layer": name, **f.properties}, f.holes)
                 for name, fs in layers.items() for f in fs]
        write_text_atomic(path, json.dumps(feature_collection(feats, georef, path.stem)) + "\n")
        return path
    with atomic_file(path, ".gpkg") as tmp:
        for name, fs in layers.items():
            if fs:
                _write_gpkg_layer(tmp, feature_collection(fs, georef, name), name, spatial_index)
    return path


def _column(values: list[Any]) -> Any:
    """A field's values as a typed array: integers, floats, else strings."""
    import numpy as np

    if all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.int64)
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.float64)
    return np.array([None if v is None else str(v) for v in values], dtype=object)


def _write_gpkg(path: Path, fc: dict[str, Any], layer: str) -> None:
    with atomic_file(path, ".gpkg") as tmp:
        _write_gpkg_layer(tmp, fc, layer)


def _write_gpkg_layer(path: Path, fc: dict[str, Any], layer: str, spatial_index: bool = True) -> None:
    """Add ``fc`` as layer ``layer`` (EPSG:4326) to the GeoPackage ``path`` (created when absent)."""
    import numpy as np
    import pyogrio.raw
    from shapely.geometry import shape

    feats = fc["features"]
    names = sorted({k for f in feats for k in f["properties"]})
    geoms = np.array([shape(f["geometry"]).wkb for f in feats], dtype=object)
    cols = [_column([f["properties"].get(k) for f in feats]) for k in names]
    kinds = {f["geometry"]["type"] for f in feats}
    pyogrio.raw.write(path, geoms, cols, names, driver="GPKG", layer=layer, crs="EPSG:4326",
                      geometry_type=kinds.pop() if len(kinds) == 1 else "Unknown", append=path.exists(),
                      layer_options=None if spatial_index else {"SPATIAL_INDEX": "NO"})
