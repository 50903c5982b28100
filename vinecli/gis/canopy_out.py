"""Canopy segments (:class:`~vinecli.rows.canopy_segments.CanopySegments`) out as GIS files: a GeoPackage layer
of one LineString per segment (EPSG:4326, through the world's georeference) and a GeoTIFF in the DSM's CRS.

GeoTIFF: float32 bands 1 leaf-wall height m, 2 width m, 3 LWA m²/ha (both sides), 4 TRV m³/ha, 5 cover 0-1;
each segment fills its row's strip of ground (± half the row spacing about the segment), gaps 0, nodata -9999
elsewhere. North-up on the local frame's grid; with a CRS frame (:class:`~vinecli.rows.source.RowFrame`) the
transform is the frame's exact linear map to the CRS, else the raster is in local metres (tag ``FRAME``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from vinecli.gis.georef import Georef
from vinecli.gis.write import LocalFeature, write_features
from vinecli.outputs import atomic_file
from vinecli.rows.canopy_segments import CanopySegments
from vinecli.rows.source import RowFrame

__all__ = ["SEGMENT_BANDS", "segment_features", "segment_strip", "write_segments_gpkg", "write_segments_tif"]

SEGMENT_BANDS = ("wall_height_m", "width_m", "lwa_m2pha", "trv_m3pha", "cover")
NODATA = -9999.0


def segment_features(segs: CanopySegments) -> list[LocalFeature]:
    """One LineString per segment with its measures as properties (rounded to mm / m² / m³)."""
    out = []
    for g in segs.segments:
        props = {"row": g.row, "s0_m": round(g.s0_m, 3), "s1_m": round(g.s1_m, 3), "gap": int(g.gap),
                 "top_m": round(g.top_m, 3), "base_m": round(g.base_m, 3), "wall_height_m": round(g.wall_height_m, 3),
                 "width_m": round(g.width_m, 3), "cover": round(g.cover, 3), "volume_m3": round(g.volume_m3, 4),
                 "lwa_m2pha": round(g.lwa_m2pha(), 1), "trv_m3pha": round(g.trv_m3pha(), 1)}
        out.append(LocalFeature("LineString", [g.start_enu, g.end_enu], props))
    return out


def write_segments_gpkg(path: Path, segs: CanopySegments, georef: Georef, layer: str = "canopy_segments") -> Path:
    """The segments as GeoPackage layer ``layer`` (or RFC 7946 GeoJSON by the suffix), atomically."""
    return write_features(path, segment_features(segs), georef, layer=layer)


def segment_strip(start: tuple[float, float], end: tuple[float, float], half: float) -> list[tuple[float, float]]:
    """The ground strip of a segment from ``start`` to ``end`` (local m), ``half`` m either side: a quadrilateral."""
    (x0, y0), (x1, y1) = start, end
    L = math.hypot(x1 - x0, y1 - y0) or 1.0
    nx, ny = -(y1 - y0) / L * half, (x1 - x0) / L * half
    return [(x0 + nx, y0 + ny), (x1 + nx, y1 + ny), (x1 - nx, y1 - ny), (x0 - nx, y0 - ny)]


def write_segments_tif(path: Path, segs: CanopySegments, frame: RowFrame | None, cell_m: float | None = None) -> Path:
    """The segments as a GeoTIFF (see the module docstring); ``cell_m`` default: an eighth of the row spacing."""
    import rasterio
    from rasterio.features import rasterize
    from rasterio.transform import Affine
    from shapely.geometry import Polygon

    if not segs.segments:
        raise ValueError("no canopy segments to write")
    half = 0.5 * segs.spacing_m
    cell = cell_m or max(segs.spacing_m / 8.0, 0.02)
    strips = [segment_strip(g.start_enu, g.end_enu, half) for g in segs.segments]
    pts = np.asarray([p for s in strips for p in s])
    x0, y0 = np.floor(pts.min(axis=0) / cell) * cell
    nx = int(np.ceil((pts[:, 0].max() - x0) / cell)) + 1
    ny = int(np.ceil((pts[:, 1].max() - y0) / cell)) + 1
    y_top = y0 + ny * cell
    pix = Affine(cell, 0.0, x0, 0.0, -cell, y_top)  # local metres, row 0 north
    label = rasterize(((Polygon(s), k + 1) for k, s in enumerate(strips)), out_shape=(ny, nx), transform=pix,
                      fill=0, dtype="int32")
    table = np.full((len(SEGMENT_BANDS), len(segs.segments) + 1), NODATA, dtype=np.float32)
    for k, g in enumerate(segs.segments, start=1):
        table[:, k] = (g.wall_height_m, g.width_m, g.lwa_m2pha(), g.trv_m3pha(), g.cover)
    tags = {"QUANTITY": "canopy segments", "SEGMENT_M": repr(segs.segment_m), "SPACING_M": repr(segs.spacing_m),
            "SOURCE": segs.source}
    profile = {"driver": "GTiff", "width": nx, "height": ny, "count": len(SEGMENT_BANDS), "dtype": "float32",
               "nodata": NODATA, "compress": "deflate", "transform": pix}
    if frame is not None and frame.crs is not None:
        (cx, cy), (sx, sy), (ox, oy) = frame.centre, frame.scale, frame.offset
        profile["transform"] = Affine(cell / sx, 0.0, (x0 - ox) / sx + cx, 0.0, -cell / sy, (y_top - oy) / sy + cy)
        profile["crs"] = frame.crs
        tags["FRAME"] = f"{frame.crs}"
    else:
        tags["FRAME"] = "local metres (x east, y north)"
    with atomic_file(Path(path), ".tif") as tmp, rasterio.open(tmp, "w", **profile) as ds:
        for b, name in enumerate(SEGMENT_BANDS, start=1):
            ds.write(table[b - 1][label], b)
            ds.set_band_description(b, name)
        ds.update_tags(**tags)
    return Path(path)
