"""GIS files -> features in a local frame: rows (lines), field boundary and fences (polygons), no-spray and
buffer zones (polygons grown by a buffer distance), from GeoJSON, Shapefile, GeoPackage, KML or KMZ in any CRS.

Every feature is checked before anything is used: a missing CRS (Shapefile without .prj, GeoPackage layer
without SRS; GeoJSON and KML are WGS84 by definition), an empty geometry, the wrong geometry type, an invalid
polygon (self-intersecting fence) or a row outside the terrain is an :class:`~vinecli.errors.InputError`
(exit 2) naming the file, the layer and the feature id.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vinecli.errors import InputError
from vinecli.gis.georef import Georef

__all__ = ["GisFeature", "read_features"]

LINES = ("LineString", "MultiLineString")
POLYGONS = ("Polygon", "MultiPolygon")
WGS84_DRIVERS = {"GeoJSON", "KML", "LIBKML", "GeoJSONSeq"}


@dataclass
class GisFeature:
    """A feature in local metres: ``layer``, ``fid`` (the file's feature id), ``parts`` (lines: [(x, y)] each;
    polygons: exterior rings, not closed), ``properties``, and each polygon part's ``holes`` (its interior rings,
    not closed; grown polygons keep theirs)."""

    layer: str
    fid: Any
    parts: list[list[tuple[float, float]]]
    properties: dict[str, Any] = field(default_factory=dict)
    holes: list[list[list[tuple[float, float]]]] = field(default_factory=list)


def read_features(path: Path | str, georef: Georef, *, expect: str, layer: str | None = None,
                  buffer_m: float = 0.0, bounds: tuple[float, float, float, float] | None = None) -> list[GisFeature]:
    """The features of ``layer`` (default: the file's first layer) in local metres. ``expect``: "lines" or
    "polygons"; polygons are grown by ``buffer_m`` (a feature's own ``buffer_m`` property wins); lines must
    lie within ``bounds`` (xmin, ymin, xmax, ymax, local m) when given."""
    import pyogrio
    from shapely import wkb

    path = Path(path)
    if not path.is_file():
        raise InputError("GIS file not found", path=path)
    src = str(path)  # GDAL opens .kmz (zipped KML) itself
    try:
        layers = [str(name) for name, _ in pyogrio.list_layers(src)]
        name = layer or layers[0]
        meta, fids, geoms, fields = pyogrio.raw.read(src, layer=name, return_fids=True)
    except (pyogrio.errors.DataSourceError, pyogrio.errors.DataLayerError) as exc:
        raise InputError(f"cannot read GIS file: {exc}", path=path) from None
    crs = meta.get("crs")
    if crs is None:
        if meta.get("driver") not in WGS84_DRIVERS and path.suffix.lower() not in (".geojson", ".json", ".kml", ".kmz"):
            raise InputError(f"layer {name!r}: no CRS (a Shapefile needs its .prj, a GeoPackage layer its SRS)",
                             path=path)
        crs = "EPSG:4326"
    want = LINES if expect == "lines" else POLYGONS
    out = []
    names = list(meta["fields"])
    for i, g in enumerate(geoms):
        fid = int(fids[i]) if fids is not None else i
        where = f"layer {name!r} feature {fid}"
        props = {k: (v.item() if hasattr(v, "item") else v) for k, v in zip(names, (f[i] for f in fields), strict=True)}
        geom = wkb.loads(bytes(g)) if g is not None else None
        if geom is None or geom.is_empty:
            raise InputError(f"{where}: empty geometry", path=path)
        if geom.geom_type not in want:
            raise InputError(f"{where}: {geom.geom_type}, expected {' or '.join(want)}", path=path)
        if expect == "polygons" and not geom.is_valid:
            from shapely.validation import explain_validity

            raise InputError(f"{where}: invalid polygon ({explain_validity(geom)})", path=path)
        parts = list(geom.geoms) if geom.geom_type.startswith("Multi") else [geom]
        local = []
        holes: list[list[list[tuple[float, float]]]] = []
        for part in parts:
            coords = [tuple(c[:2]) for c in (part.exterior.coords[:-1] if expect == "polygons" else part.coords)]
            local.append(_checked(georef.from_crs(coords, crs), coords, crs, where, path))
            if expect == "polygons":
                inner = [[tuple(c[:2]) for c in ring.coords[:-1]] for ring in part.interiors]
                holes.append([_checked(georef.from_crs(r, crs), r, crs, where, path) for r in inner])
        grow = float(props.get("buffer_m") or buffer_m)
        if expect == "polygons" and grow != 0:
            local, holes = _buffered(local, holes, grow)
        elif expect != "polygons" and bounds is not None:
            _check_inside(local, bounds, where, path)
        out.append(GisFeature(name, fid, local, props, holes))
    if not out:
        raise InputError(f"layer {name!r}: no features", path=path)
    return out


#: local coordinates farther than this from the world's origin are not a field (a wrong CRS), m
MAX_LOCAL_M = 100_000.0


def _checked(local: list[tuple[float, float]], coords: list[tuple[float, ...]], crs: Any, where: str,
             path: Path) -> list[tuple[float, float]]:
    """``local`` when every point is finite and within :data:`MAX_LOCAL_M` of the world; else InputError naming
    the first bad point in the file's CRS (GeoJSON and KML are WGS84 longitude/latitude by definition)."""
    import math

    for (x, y), c in zip(local, coords, strict=True):
        if not (math.isfinite(x) and math.isfinite(y)) or max(abs(x), abs(y)) > MAX_LOCAL_M:
            hint = (" (GeoJSON and KML hold WGS84 longitude/latitude: projected coordinates need a Shapefile with its "
                    ".prj or a GeoPackage layer with its SRS)" if str(crs).upper() in ("EPSG:4326", "OGC:CRS84") else "")
            raise InputError(f"{where}: point ({c[0]:.10g}, {c[1]:.10g}) in {crs} is not near the world "
                             f"({'not a valid position' if not (math.isfinite(x) and math.isfinite(y)) else f'{max(abs(x), abs(y)) / 1000:.0f} km away'})"
                             f": wrong CRS?{hint}", path=path)
    return local


def _buffered(rings: list[list[tuple[float, float]]], holes: list[list[list[tuple[float, float]]]], buffer_m: float
              ) -> tuple[list[list[tuple[float, float]]], list[list[list[tuple[float, float]]]]]:
    """Polygons (exterior rings and their holes) grown by ``buffer_m`` metres (mitred corners) in the local frame."""
    from shapely.geometry import Polygon

    out, out_holes = [], []
    for r, h in zip(rings, holes, strict=True):
        g = Polygon(r, h).buffer(buffer_m, join_style="mitre")
        polys = [p for p in (list(g.geoms) if g.geom_type == "MultiPolygon" else [g]) if not p.is_empty]
        out += [[(float(x), float(y)) for x, y in p.exterior.coords[:-1]] for p in polys]
        out_holes += [[[(float(x), float(y)) for x, y in i.coords[:-1]] for i in p.interiors] for p in polys]
    return out, out_holes


def _check_inside(lines: list[list[tuple[float, float]]], bounds: tuple[float, float, float, float], where: str,
                  path: Path) -> None:
    xmin, ymin, xmax, ymax = bounds
    for line in lines:
        for x, y in line:
            if not (xmin <= x <= xmax and ymin <= y <= ymax):
                raise InputError(f"{where}: row point ({x:.2f}, {y:.2f}) m is outside the terrain "
                                 f"[{xmin:.2f}, {ymin:.2f}, {xmax:.2f}, {ymax:.2f}]", path=path)
