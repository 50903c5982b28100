"""``gis:`` in a world spec: the grower's rows, fence and no-spray zones from GIS files, into the world.

Read with :func:`vinecli.gis.read.read_features` through the world's georeference (the DSM's CRS for a world
built from a DSM with a CRS, else the topocentric frame of the world's origin: :func:`vinecli.gis.georef.
world_georef`), so the features land on the terrain where a GIS shows them. Rows must lie on the terrain;
the fence is one polygon (its exterior ring becomes the geofence's inclusion polygon); rows of any source
(``rows:``, ``rows: auto``, ``gis.rows``) are cut where they cross a no-spray zone (grown by its buffer), so the
sprayer is off there: each remaining stretch is a row of ``vine_rows_enu``, and ``world.json`` ``gis`` records
which row and feature it came from.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vinecli.errors import InputError
from vinecli.gis.georef import Georef
from vinecli.gis.read import read_features
from vinecli.world.spec import WorldGisSpec

__all__ = ["GisWorld", "cut_rows", "gis_sources", "read_world_gis"]

Ring = list[tuple[float, float]]

#: stretches of a row shorter than this left between no-spray zones are dropped, m
MIN_STRETCH_M = 0.5


@dataclass
class GisWorld:
    """What the GIS files give a world (local ENU metres): rows (None: not given), their sources (file layer
    and feature id), the fence's ring (None: not given), the no-spray zones (grown rings)."""

    rows: list[Ring] | None = None
    row_sources: list[dict[str, Any]] = field(default_factory=list)
    fence: Ring | None = None
    no_spray: list[Ring] = field(default_factory=list)
    files: dict[str, Any] = field(default_factory=dict)


def gis_sources(gis: WorldGisSpec | None, base: Path) -> list[Path]:
    """The GIS files a world spec reads (resolved against the spec's directory ``base``)."""
    if gis is None:
        return []
    layers = [x for x in (gis.rows, gis.fence, *gis.no_spray) if x is not None]
    return [p if p.is_absolute() else base / p for p in (x.path for x in layers)]


def read_world_gis(gis: WorldGisSpec, base: Path, georef: Georef, bounds: tuple[float, float, float, float]
                   ) -> GisWorld:
    """Read the spec's GIS layers into the world frame (see the module docstring); bad features raise
    :class:`~vinecli.errors.InputError` naming the file, layer and feature."""
    out = GisWorld()

    def path(p: Path) -> Path:
        return p if p.is_absolute() else base / p

    if gis.rows is not None:
        src = path(gis.rows.path)
        feats = read_features(src, georef, expect="lines", layer=gis.rows.layer, bounds=bounds)
        out.rows, out.row_sources = [], []
        for f in feats:
            for k, part in enumerate(f.parts):
                out.rows.append(part)
                out.row_sources.append({"layer": f.layer, "fid": f.fid, "part": k})
        out.files["rows"] = {"path": str(src), "layer": feats[0].layer, "features": len(feats)}
    if gis.fence is not None:
        src = path(gis.fence.path)
        feats = read_features(src, georef, expect="polygons", layer=gis.fence.layer)
        if len(feats) != 1 or len(feats[0].parts) != 1:
            n = sum(len(f.parts) for f in feats)
            raise InputError(f"layer {feats[0].layer!r}: the fence must be one polygon, found {n}", path=src)
        out.fence = feats[0].parts[0]
        out.files["fence"] = {"path": str(src), "layer": feats[0].layer, "fid": feats[0].fid}
    for z in gis.no_spray:
        src = path(z.path)
        feats = read_features(src, georef, expect="polygons", layer=z.layer, buffer_m=z.buffer_m)
        out.no_spray += [ring for f in feats for ring in f.parts]
        out.files.setdefault("no_spray", []).append({"path": str(src), "layer": feats[0].layer,
                                                     "features": len(feats), "buffer_m": z.buffer_m})
    return out


def cut_rows(rows: list[Ring], sources: list[dict[str, Any]], zones: list[Ring]
             ) -> tuple[list[Ring], list[dict[str, Any]]]:
    """Rows minus the no-spray zones: the stretches left (in order along each row, at least
    :data:`MIN_STRETCH_M` long) and their sources (``row``: index of the row they came from, plus the row's own
    source)."""
    from shapely.geometry import LineString, Point, Polygon
    from shapely.ops import linemerge, unary_union

    if not zones:
        return rows, [{"row": i, **s} for i, s in enumerate(sources)]
    area = unary_union([Polygon(z) for z in zones])
    out: list[Ring] = []
    src: list[dict[str, Any]] = []
    for i, (row, s) in enumerate(zip(rows, sources, strict=True)):
        line = LineString(row)
        left = line.difference(area)
        if left.geom_type == "MultiLineString":
            left = linemerge(left)
        stretches = []
        for g in getattr(left, "geoms", [left]):
            if g.is_empty or g.length < MIN_STRETCH_M:
                continue
            c = list(g.coords)
            a, b = line.project(Point(c[0])), line.project(Point(c[-1]))
            stretches.append((min(a, b), c if a <= b else c[::-1]))  # along the row, as the row runs
        for _, c in sorted(stretches, key=lambda x: x[0]):
            out.append([(round(float(x), 4), round(float(y), 4)) for x, y in c])
            src.append({"row": i, **s})
    return out, src
