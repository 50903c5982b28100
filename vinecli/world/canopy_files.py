"""A world's canopy segments on disk (docs/dose.md): ``canopy_segments.json`` (schema
``vinecli.canopy_segments/1``, :class:`~vinecli.rows.canopy_segments.CanopySegments`, world ENU m),
``canopy_segments.gpkg`` (layer ``canopy_segments``, EPSG:4326) and ``canopy_segments.tif`` (in the DSM's CRS
for a DSM world), written by ``world build``; world.json ``canopy.segments`` names them with the summary."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from vinecli.geo import GeoOrigin
from vinecli.gis.canopy_out import write_segments_gpkg, write_segments_tif
from vinecli.gis.georef import Georef
from vinecli.outputs import write_json
from vinecli.rows.canopy_segments import CanopySegments
from vinecli.rows.source import terrain_frame

__all__ = ["SEGMENTS_GPKG", "SEGMENTS_JSON", "SEGMENTS_TIF", "load_canopy_segments", "write_canopy_segments"]

SEGMENTS_JSON = "canopy_segments.json"
SEGMENTS_GPKG = "canopy_segments.gpkg"
SEGMENTS_TIF = "canopy_segments.tif"


def write_canopy_segments(world_dir: Path, segs: CanopySegments, terrain: dict[str, Any], terrain_dir: Path,
                          origin: GeoOrigin) -> dict[str, Any]:
    """Write the three files into ``world_dir`` (the world being built); returns world.json's ``canopy.segments``."""
    frame = terrain_frame(terrain, terrain_dir)
    write_json(world_dir / SEGMENTS_JSON, segs.to_dict())
    files = [SEGMENTS_JSON]
    if segs.segments:
        write_segments_gpkg(world_dir / SEGMENTS_GPKG, segs,
                            Georef(frame if frame is not None and frame.crs is not None else None, origin))
        write_segments_tif(world_dir / SEGMENTS_TIF, segs, frame)
        files += [SEGMENTS_GPKG, SEGMENTS_TIF]
    return {"files": files, **segs.summary()}


def load_canopy_segments(world_dir: Path | str) -> CanopySegments | None:
    """The segments ``world build`` wrote into ``world_dir``; None for a world without them."""
    p = Path(world_dir) / SEGMENTS_JSON
    if not p.is_file():
        return None
    return CanopySegments.from_dict(json.loads(p.read_text(encoding="utf-8")))
