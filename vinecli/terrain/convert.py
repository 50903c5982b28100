"""``vinecli terrain convert``: a DSM GeoTIFF -> a PyBullet/Gazebo heightmap
(:func:`vinecli.terrain.heightmap.convert_to_heightmap`) or error-bounded mesh tiles
(:func:`vinecli.terrain.tiles.convert_to_tiles`), refusing the options of the other kind.
Light to import; the converters are loaded on demand."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from vinecli.errors import InputError
from vinecli.terrain.defaults import FILL, HEIGHTMAP_METHOD, TILE_FORMAT, TILE_PX

if TYPE_CHECKING:
    from vinecli.terrain.heightmap import Heightmap
    from vinecli.terrain.tiles import TileSet

#: what ``to`` may be
TARGETS = ("heightmap", "tiles")


# parameters: keyword-only options, each with its default, one per `vinecli terrain convert` option; a caller names the ones it sets
def convert_dsm(dsm: Path, out: Path, *, to: str, size: int | None = None, method: str = HEIGHTMAP_METHOD,
                window: str | None = None, bbox: str | None = None, fill: str = FILL, z_unit: str | None = None,
                max_error: float | None = None, max_triangles: int | None = None, tile_px: int = TILE_PX,
                fmt: str = TILE_FORMAT, workers: int | None = None, overwrite: bool = False) -> Heightmap | TileSet:
    """Convert ``dsm`` into ``out`` as ``to`` (heightmap or tiles). ``size``, ``method``, ``window``
    (``"COL,ROW,WIDTH,HEIGHT"`` pixels) and ``bbox`` (``"MINX,MINY,MAXX,MAXY"`` CRS units) apply to a heightmap;
    ``max_error``, ``max_triangles``, ``tile_px``, ``fmt`` and ``workers`` to tiles. InputError naming ``dsm``
    for an option of the other kind (a non-default one) or an unknown ``to``."""
    hm_only = {"--size": size, "--window": window, "--bbox": bbox}
    tiles_only = {"--max-error": max_error, "--max-triangles": max_triangles, "--workers": workers}
    if to == "heightmap":
        bad = [k for k, v in tiles_only.items() if v is not None] + (["--format"] if fmt != TILE_FORMAT else [])
        if bad:
            raise InputError(f"{', '.join(bad)} apply to --to tiles only", path=dsm)
        from vinecli.terrain.crop import parse_floats, parse_ints
        from vinecli.terrain.heightmap import convert_to_heightmap

        return convert_to_heightmap(
            dsm, out, size=size, method=method,
            window=parse_ints(window, 4, "--window", path=dsm) if window else None,  # type: ignore[arg-type]
            bbox=parse_floats(bbox, 4, "--bbox", path=dsm) if bbox else None,  # type: ignore[arg-type]
            fill=fill, z_unit=z_unit, overwrite=overwrite)
    if to == "tiles":
        bad = [k for k, v in hm_only.items() if v is not None] + (["--method"] if method != HEIGHTMAP_METHOD else [])
        if bad:
            raise InputError(f"{', '.join(bad)} apply to --to heightmap only", path=dsm)
        from vinecli.terrain.tiles import convert_to_tiles

        return convert_to_tiles(dsm, out, max_error=max_error, max_triangles=max_triangles, tile_px=tile_px, fmt=fmt,
                                fill=fill, z_unit=z_unit, workers=workers, overwrite=overwrite)
    raise InputError(f"--to {to!r}: choose {' or '.join(TARGETS)}", path=dsm)
