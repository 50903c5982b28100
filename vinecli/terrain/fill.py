"""Fill nodata holes in a height grid before it is resampled or meshed.

Methods (``fill`` option):

* ``idw`` (default): GDAL FillNodata (inverse-distance weighting from the hole's edge, searching
  up to :data:`IDW_SEARCH_PX` pixels), then nearest-valid for anything left;
* ``nearest``: each hole pixel takes the value of the nearest valid pixel (scipy Euclidean
  distance transform);
* ``min``: the lowest valid height (e.g. water as low ground);
* a number: that height in metres.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vinecli.errors import InputError, TerrainError
from vinecli.terrain.defaults import FILL

log = logging.getLogger(__name__)

FILL_CHOICES: tuple[str, ...] = ("idw", "nearest", "min")
#: Search radius of GDAL FillNodata, pixels.
IDW_SEARCH_PX = 100


@dataclass(frozen=True)
class FillResult:
    """What filling did: method description and share of the grid that was filled (0..1)."""

    method: str
    filled_fraction: float
    filled_pixels: int


def parse_fill(text: str | float | None, *, path: Path | None = None) -> str | float:
    """Validate a ``--fill`` value: one of :data:`FILL_CHOICES` or a height in metres."""
    if text is None:
        return "idw"
    if isinstance(text, (int, float)):
        return float(text)
    t = str(text).strip().lower()
    if t in FILL_CHOICES:
        return t
    try:
        return float(t)
    except ValueError:
        raise InputError(f"--fill {text!r}: choose {', '.join(FILL_CHOICES)} or a height in metres",
                         path=path) from None


def _nearest(z: np.ndarray, holes: np.ndarray) -> None:
    from scipy import ndimage

    idx = ndimage.distance_transform_edt(holes, return_distances=False, return_indices=True)
    z[holes] = z[idx[0][holes], idx[1][holes]]


def fill_nodata(z: np.ndarray, fill: str | float = FILL, *, path: Path | None = None) -> FillResult:
    """Fill NaNs of ``z`` (float32 metres, modified in place). TerrainError if all of it is NaN."""
    holes = np.isnan(z)
    n = int(holes.sum())
    if n == z.size:
        raise TerrainError("no valid heights: every pixel of the area is nodata", path=path)
    if n == 0:
        return FillResult("none (no nodata)", 0.0, 0)
    fill = parse_fill(fill)
    if isinstance(fill, float):
        z[holes] = fill
        desc = f"constant {fill:g} m"
    elif fill == "min":
        z[holes] = np.nanmin(z)
        desc = "constant: minimum valid height"
    elif fill == "nearest":
        _nearest(z, holes)
        desc = "nearest valid pixel (scipy distance transform)"
    else:
        from rasterio.fill import fillnodata

        filled = fillnodata(z, mask=(~holes).astype(np.uint8), max_search_distance=IDW_SEARCH_PX, smoothing_iterations=0)
        z[...] = filled
        left = np.isnan(z)
        desc = f"inverse-distance weighting (GDAL FillNodata, {IDW_SEARCH_PX} px search)"
        if left.any():
            _nearest(z, left)
            desc += f", then nearest valid pixel for {int(left.sum())} px beyond the search radius"
    log.info("filled %d nodata px (%.3f%%): %s", n, 100 * n / z.size, desc)
    return FillResult(desc, n / z.size, n)
