"""Defaults of the terrain conversions, declared once for the library (:mod:`vinecli.terrain.heightmap`,
:mod:`vinecli.terrain.tiles`, :mod:`vinecli.terrain.fill`, :mod:`vinecli.terrain.pointcloud`) and the
``vinecli terrain`` commands. Plain Python, light to import: the command line reads them for its options."""

from __future__ import annotations

from typing import Final

#: heightmap resampling method
HEIGHTMAP_METHOD: Final = "bilinear"
#: nodata fill (idw, nearest, min, or a height in m)
FILL: Final = "idw"
#: mesh tiles: tile step in pixels (neighbours share a border row/column)
TILE_PX: Final = 256
#: mesh tiles: smallest tile step, px, and most tiles one conversion may make (a 2 px step on a survey
#: would make hundreds of thousands of 3×3-sample meshes)
MIN_TILE_PX: Final = 8
MAX_TILES: Final = 10_000
#: mesh tiles: file format
TILE_FORMAT: Final = "obj"
#: point-cloud meshing method (ball pivoting)
RECONSTRUCT_METHOD: Final = "bpa"
