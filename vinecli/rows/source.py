"""Where rows are detected: a DSM GeoTIFF or a built world, and how row coordinates map to a CRS.

Every caller (``world build`` with ``rows: auto``, ``plan rows``, the run-time detection) goes through
:func:`detect_rows_in_dsm` or :func:`detect_rows_on_grid`, which both call the one detector
:func:`vinecli.rows.detect.detect_rows_grid`.

Frames. The terrain tools put a raster in *local metres along the CRS axes about a centre* (x =
(X - cx) * sx, y = (Y - cy) * sy; sx, sy in m per CRS unit: 1 for metres, 0.3048 for feet, metres per
degree at the centre for a geographic CRS), and a world adds a constant ENU offset when its origin
differs. :class:`RowFrame` is that mapping, so rows detected on the DSM land on the world's terrain
exactly, and rows go back to the source CRS (and WGS84, :mod:`vinecli.gis`).
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import TerrainError
from vinecli.geo import GeoOrigin
from vinecli.rows.detect import NoRowsError, Polyline, RowDetection, detect_rows_grid

__all__ = ["DsmRows", "RowFrame", "detect_rows_in_dsm", "detect_rows_on_grid", "dsm_rows_in_frame", "terrain_frame",
           "world_frame"]


@dataclass(frozen=True)
class RowFrame:
    """Local metres (x east, y north) <-> CRS: ``x = (X - cx) * sx + ox``, ``y = (Y - cy) * sy + oy``.

    ``crs`` is a CRS label (``EPSG:n`` or WKT) or None (then X, Y are the raster's own units, taken as m).
    """

    crs: str | None
    centre: tuple[float, float]
    scale: tuple[float, float] = (1.0, 1.0)
    offset: tuple[float, float] = (0.0, 0.0)

    def to_crs(self, pts: Polyline) -> list[tuple[float, float]]:
        """Local metres -> CRS coordinates."""
        (cx, cy), (sx, sy), (ox, oy) = self.centre, self.scale, self.offset
        return [((x - ox) / sx + cx, (y - oy) / sy + cy) for x, y in pts]

    def from_crs(self, pts: list[tuple[float, float]]) -> Polyline:
        """CRS coordinates -> local metres."""
        (cx, cy), (sx, sy), (ox, oy) = self.centre, self.scale, self.offset
        return [((x - cx) * sx + ox, (y - cy) * sy + oy) for x, y in pts]

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"crs": self.crs, "centre_crs": list(self.centre), "m_per_crs_unit": list(self.scale),
                "offset_enu": list(self.offset)}


def crs_scale(crs: Any, lat: float | None) -> tuple[float, float]:
    """Metres per CRS unit along x and y: linear unit factor, or metres per degree at ``lat`` (geographic)."""
    if crs is None:
        return 1.0, 1.0
    from vinecli.terrain.raster import horizontal_crs, metres_per_degree

    hc = horizontal_crs(crs)
    if hc.is_geographic:
        m_lat, m_lon = metres_per_degree(lat or 0.0)
        return m_lon, m_lat
    f = float(hc.axis_info[0].unit_conversion_factor or 1.0)
    return f, f


@dataclass
class DsmRows:
    """Rows detected on a DSM: the detection (local metres), its frame, the geodetic origin of the raster
    centre (None without CRS) and the height grid used (``x`` (nx,), ``y`` (ny,), ``z`` (ny, nx), m)."""

    detection: RowDetection
    frame: RowFrame
    origin: GeoOrigin | None
    grid: dict[str, np.ndarray] = field(default_factory=dict)

    @functools.cached_property
    def median_z(self) -> float:
        """Median surface height of the grid (fills holes), m."""
        return float(np.nanmedian(self.grid["z"]))

    @functools.cached_property
    def _interp(self) -> Any:
        from scipy.interpolate import RegularGridInterpolator

        z = np.where(np.isfinite(self.grid["z"]), self.grid["z"], self.median_z)
        return RegularGridInterpolator((self.grid["y"], self.grid["x"]), z, bounds_error=False, fill_value=np.nan)

    def height(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Surface height (m, raster's vertical datum) at local positions: bilinear, NaN outside the grid
        (the interpolator is built once per detection)."""
        return self._interp(np.column_stack([np.asarray(ys, float), np.asarray(xs, float)]))


def detect_rows_in_dsm(path: Path | str, *, max_cells: int = 300_000, **kw: Any) -> DsmRows:
    """Rows in a north-up DSM GeoTIFF, in local metres along the CRS axes about the raster-bounds centre
    (as ``terrain convert --to tiles``); ``kw`` go to :func:`detect_rows_grid`."""
    import rasterio

    from vinecli.terrain.raster import check_dsm_size, check_suffix, crs_label, to_lonlat

    path = Path(path)
    check_suffix(path)
    try:
        with rasterio.open(path) as ds:
            check_dsm_size(ds.width, ds.height, path)
            f = max(1, math.ceil(math.sqrt(ds.width * ds.height / max_cells)))
            shape = (max(8, ds.height // f), max(8, ds.width // f))
            z = ds.read(1, out_shape=shape, masked=True, resampling=rasterio.enums.Resampling.average)
            z = np.ma.filled(z.astype(float), np.nan)
            tr = ds.transform @ ds.transform.scale(ds.width / shape[1], ds.height / shape[0])
            crs = ds.crs
            b = ds.bounds
    except rasterio.errors.RasterioError as exc:
        raise TerrainError(f"cannot read raster: {exc}", path=path) from None
    if abs(tr.b) > 1e-12 or abs(tr.d) > 1e-12:
        raise TerrainError("rotated/skewed geotransform: row detection needs a north-up raster", path=path)
    z[~np.isfinite(z) | (np.abs(z) > 1e6)] = np.nan
    if not np.isfinite(z).any():
        raise TerrainError("no valid heights (every pixel is nodata)", path=path)
    cx, cy = (b.left + b.right) / 2, (b.bottom + b.top) / 2
    origin = None
    if crs is not None:
        lon, lat = to_lonlat(crs, cx, cy)
        origin = GeoOrigin(float(lat), float(lon), float(np.nanmedian(z)))
    sx, sy = crs_scale(crs, origin.lat if origin else None)
    frame = RowFrame(crs_label(crs), (float(cx), float(cy)), (sx, sy))
    ny, nx = z.shape
    x = (tr.c + (np.arange(nx) + 0.5) * tr.a - cx) * sx
    y = (tr.f + (np.arange(ny) + 0.5) * tr.e - cy) * sy
    if y[1] < y[0]:
        z, y = z[::-1], y[::-1]
    try:
        det = detect_rows_grid(z, x, y, **kw)
    except NoRowsError as exc:
        raise NoRowsError(exc.problem, exc.evidence, path=path) from None
    except TerrainError as exc:
        raise TerrainError(exc.problem, path=path) from None
    return DsmRows(det, frame, origin, {"x": x, "y": y, "z": z})


def detect_rows_on_grid(grid: Any, **kw: Any) -> RowDetection:
    """Rows on a world's height grid (:class:`~vinecli.terrain.grid.TerrainGrid`, ENU m)."""
    p = grid.preview(10**9)  # full resolution
    return detect_rows_grid(np.asarray(p["z"], float), np.asarray(p["x"], float), np.asarray(p["y"], float), **kw)


def terrain_frame(t: dict[str, Any], terrain_dir: Path) -> RowFrame | None:
    """The CRS frame of a built DSM terrain (world.json ``terrain`` and its directory): centre and CRS from
    tiles.json / heightmap.json, ENU offset from the world (None for flat terrain). Without a CRS the frame
    still maps the raster's own coordinates (``crs`` None, 1 m per unit)."""
    if t["kind"] == "tiles":
        meta = json.loads((terrain_dir / "tiles.json").read_text())
        crs, centre = meta["origin"].get("crs"), meta["origin"]["crs_xy"]
        geo = meta["origin"].get("geodetic") or {}
        off = list(t.get("offset_enu", [0.0, 0.0]))[:2]
    elif t["kind"] == "heightmap":
        meta = json.loads((terrain_dir / "heightmap.json").read_text())
        crs, centre = meta.get("crs"), meta["origin"]
        geo = meta.get("geodetic_origin") or {}
        xmin, ymin, xmax, ymax = t["bounds_enu"]
        off = [(xmin + xmax) / 2, (ymin + ymax) / 2]  # the heightmap is centred on its centre vertex
    else:
        return None
    scale = (1.0, 1.0)
    if crs is not None:
        from pyproj import CRS  # (rasterio's CRS gives the same scale: loading a world does not load GDAL)

        scale = crs_scale(CRS.from_user_input(crs), geo.get("lat"))
    return RowFrame(crs, (float(centre[0]), float(centre[1])), scale, (float(off[0]), float(off[1])))


def world_frame(world_dir: Path | str) -> RowFrame | None:
    """:func:`terrain_frame` of a built world directory."""
    root = Path(world_dir)
    d = json.loads((root / "world.json").read_text())
    return terrain_frame(d["terrain"], root / "terrain")


def dsm_rows_in_frame(dsm: DsmRows, frame: RowFrame) -> list[Polyline]:
    """Rows detected on a DSM, in another frame of the same raster (e.g. a world's ENU)."""
    return [[(round(x, 3), round(y, 3)) for x, y in frame.from_crs(dsm.frame.to_crs(r))] for r in dsm.detection.rows]
