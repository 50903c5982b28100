"""What a field map is made of: layers of features in the world's local metres (x east, y north) and rasters on a
local grid, each with its legend; turned into the browser's data (WGS84 longitude/latitude, rasters as PNG
overlays on the Web-Mercator grid Leaflet draws in) by :func:`map_data` through the world's georeference.

A layer is one small function of a :class:`~vinecli.report.fieldmap.context.MapContext` returning a
:class:`MapLayer` (or None when the run has nothing for it); :data:`vinecli.report.fieldmap.run_map.LAYERS` lists them
in drawing order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vinecli.gis.georef import Georef
from vinecli.gis.write import LocalFeature

__all__ = ["Legend", "LocalFeature", "MapLayer", "Raster", "map_data"]


@dataclass
class Raster:
    """A raster on a local grid: ``rgba`` (ny, nx, 4) uint8, row 0 SOUTH, cell ``cell_m`` from the south-west
    corner (``x0_m``, ``y0_m``). ``values`` (ny, nx), NaN where empty: what hovering shows, as "``label`` value
    ``unit``" with ``digits`` decimals (and the share of ``ref``, e.g. the asked rate, when given).
    ``smooth``: bilinear resampling (terrain) instead of nearest (cells). ``values_px``: the hover grid's long side
    (pixels; mostly coarser than the image: hover values cost more bytes than colours; finer for a
    deposition, whose cells the cursor must read one by one)."""

    rgba: np.ndarray
    x0_m: float
    y0_m: float
    cell_m: float
    values: np.ndarray | None = None
    label: str = ""
    unit: str = ""
    digits: int = 1
    ref: float | None = None
    ref_label: str = ""
    smooth: bool = False
    values_px: int = 256


@dataclass
class Legend:
    """Swatches (css colour, label, kind "line" | "dash" | "fill" | "dot") and/or a colour scale: a horizontal
    gradient (``scale_colours``: css colours from the low to the high end) with ``ticks`` (fraction 0-1, label)."""

    swatches: list[tuple[str, str, str]] = field(default_factory=list)
    scale_colours: list[str] = field(default_factory=list)
    ticks: list[tuple[float, str]] = field(default_factory=list)
    unit: str = ""


@dataclass
class MapLayer:
    """One layer of the map. ``features``: vectors in local metres whose properties ``tip`` (hover text) and
    ``style`` (Leaflet path options, over the layer's ``style``) the page reads, ``check`` names the failed check a
    feature locates; ``raster``: an image overlay. ``visible``: shown when the page opens."""

    key: str
    name: str
    features: list[LocalFeature] = field(default_factory=list)
    raster: Raster | None = None
    style: dict[str, Any] = field(default_factory=dict)
    visible: bool = True
    legend: Legend | None = None
    note: str = ""


def map_data(layers: list[MapLayer], georef: Georef, *, view_local: tuple[float, float, float, float],
             title: str = "", note: str = "", max_px: int = 640) -> dict[str, Any]:
    """The browser's data of a map: layers with their features as GeoJSON (lon/lat) and rasters as PNG overlays
    (:func:`vinecli.report.fieldmap.overlay.overlay`), the view (south-west, north-east lat/lon of the local box
    ``view_local`` = (xmin, ymin, xmax, ymax) m)."""
    from vinecli.report.fieldmap.overlay import overlay

    coords = [p for lay in layers for f in lay.features for p in _points(f)]
    x0, y0, x1, y1 = view_local
    box = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    ll = georef.to_lonlat(coords + box) if coords or box else []
    it = iter(ll)
    out = []
    for lay in layers:
        feats = []
        for i, f in enumerate(lay.features):
            geom = _geometry(f, it)
            props = {k: v for k, v in f.properties.items() if v is not None}
            feats.append({"type": "Feature", "id": i, "properties": props, "geometry": geom})
        d: dict[str, Any] = {"key": lay.key, "name": lay.name, "visible": lay.visible, "style": lay.style,
                             "note": lay.note, "features": {"type": "FeatureCollection", "features": feats}}
        if lay.raster is not None:
            d["raster"] = overlay(lay.raster, georef, max_px=max_px)
        if lay.legend is not None:
            lg = lay.legend
            d["legend"] = {"swatches": lg.swatches, "scale": lg.scale_colours, "ticks": lg.ticks, "unit": lg.unit}
        out.append(d)
    corners = [next(it) for _ in box]
    lons, lats = [c[0] for c in corners], [c[1] for c in corners]
    return {"title": title, "note": note, "layers": out,
            "view": [[min(lats), min(lons)], [max(lats), max(lons)]]}


def _points(f: LocalFeature) -> list[tuple[float, float]]:
    return [*f.coords, *(p for h in f.holes for p in h)]


def _geometry(f: LocalFeature, it: Any) -> dict[str, Any]:
    def take(n: int) -> list[list[float]]:
        return [[round(lon, 8), round(lat, 8)] for lon, lat in (next(it) for _ in range(n))]

    if f.kind == "Point":
        return {"type": "Point", "coordinates": take(1)[0]}
    if f.kind == "Polygon":
        rings = [take(len(f.coords)), *(take(len(h)) for h in f.holes)]
        return {"type": "Polygon", "coordinates": [r + r[:1] for r in rings]}
    return {"type": "LineString", "coordinates": take(len(f.coords))}
