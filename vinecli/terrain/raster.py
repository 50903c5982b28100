"""Open and validate a DSM GeoTIFF; its units, CRS and nodata mask.

What is accepted: a single-band GeoTIFF (``.tif``/``.tiff``) of real numbers (int16, float32,
float64, ...), north-up (no rotation), with a projected, compound (e.g. EPSG:7415 = RD New +
NAP), geographic (degrees) or missing CRS.

Units:

* horizontal: from the CRS axes (metre, foot, US survey foot, degree). No CRS: metres, with a
  warning, and the geodetic origin is then unknown.
* vertical (heights), first match wins: the ``z_unit`` option, the band's unit type
  (GDAL ``units``), the vertical axis of a compound/3-D CRS, else the horizontal linear unit of a
  projected CRS (state-plane DEMs in feet carry heights in feet), else metres.
  Band scale/offset are applied before the unit conversion.

Nodata is masked in the file's own dtype before any conversion, so a float64 sentinel such as
``-1.7e308`` never reaches float32 (where it would become ``-inf``). Heights leave this module
as float32 metres with NaN where there is no data.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError, TerrainError
from vinecli.inputs import note_input, read_input_json, require_regular_file
from vinecli.specs.limits import MAX_DSM_PX

log = logging.getLogger(__name__)

RASTER_SUFFIXES: tuple[str, ...] = (".tif", ".tiff")
CLOUD_SUFFIXES: tuple[str, ...] = (".las", ".laz", ".ply", ".pcd", ".xyz", ".txt", ".csv")

FOOT_M = 0.3048
US_FOOT_M = 1200.0 / 3937.0

#: unit names seen in CRS axes and GDAL band unit types -> metres per unit
_UNITS: dict[str, tuple[str, float]] = {
    "m": ("metre", 1.0), "metre": ("metre", 1.0), "meter": ("metre", 1.0), "metres": ("metre", 1.0),
    "meters": ("metre", 1.0), "ft": ("foot", FOOT_M), "foot": ("foot", FOOT_M), "feet": ("foot", FOOT_M),
    "international foot": ("foot", FOOT_M), "intl foot": ("foot", FOOT_M),
    "us-ft": ("US survey foot", US_FOOT_M), "us_ft": ("US survey foot", US_FOOT_M), "ftus": ("US survey foot", US_FOOT_M),
    "us survey foot": ("US survey foot", US_FOOT_M), "us foot": ("US survey foot", US_FOOT_M),
    "foot_us": ("US survey foot", US_FOOT_M), "us-foot": ("US survey foot", US_FOOT_M),
}
Z_UNIT_CHOICES: tuple[str, ...] = ("m", "ft", "us-ft")

#: Block size (pixels) of streamed whole-raster scans (:func:`scan_heights`).
SCAN_CHUNK_PX = 1 << 22
#: GDAL block cache for our reads (MB); GDAL's default is 5% of RAM, which would hold a whole DSM.
GDAL_CACHE_MB = 32


def unit_factor(name: str | None) -> tuple[str, float] | None:
    """(canonical name, metres per unit) for a unit name, or None if unknown/empty."""
    if not name:
        return None
    return _UNITS.get(name.strip().lower())


@dataclass(frozen=True)
class Units:
    """How raster coordinates and values become metres.

    ``xy_to_m``: metres per CRS unit (1.0 and ``geographic=True`` for degrees, which need a
    local projection). ``z_source``: where the vertical unit came from (``option``,
    ``band-unit``, ``crs-vertical-axis``, ``assumed-horizontal``, ``assumed-metre``).
    """

    xy_unit: str
    xy_to_m: float
    z_unit: str
    z_to_m: float
    z_source: str
    geographic: bool = False
    xy_assumed: bool = False

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return asdict(self)


@dataclass(frozen=True)
class DsmMeta:
    """A validated DSM: shape, georeferencing (north-up affine, CRS units), units, nodata.

    ``transform`` maps (col, row) of pixel *corners* to CRS coordinates; pixel centres are at
    half-integer indices. ``crs`` is a ``rasterio.crs.CRS`` or None.
    """

    path: Path
    width: int
    height: int
    dtype: str
    nodata: float | None
    transform: Any
    crs: Any
    units: Units
    scale: float
    offset: float
    driver: str
    tiled: bool
    block_shape: tuple[int, int]
    compress: str | None
    has_dataset_mask: bool
    warnings: tuple[str, ...] = ()

    @property
    def pixel_size(self) -> tuple[float, float]:
        """(x, y) pixel size in CRS units (positive)."""
        return (abs(float(self.transform.a)), abs(float(self.transform.e)))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """Outer pixel edges (minx, miny, maxx, maxy), CRS units."""
        t = self.transform
        return (t.c, t.f + t.e * self.height, t.c + t.a * self.width, t.f)

    @property
    def sample_extent(self) -> tuple[float, float, float, float]:
        """Extent of the pixel *centres* (minx, miny, maxx, maxy), CRS units."""
        px, py = self.pixel_size
        x0, y0, x1, y1 = self.bounds
        return (x0 + px / 2, y0 + py / 2, x1 - px / 2, y1 - py / 2)

    @property
    def centre(self) -> tuple[float, float]:
        """Centre of the raster bounds, CRS units."""
        x0, y0, x1, y1 = self.bounds
        return ((x0 + x1) / 2, (y0 + y1) / 2)

    @property
    def crs_label(self) -> str | None:
        """``EPSG:nnnn`` when the CRS has a code, else its WKT; None without CRS."""
        return crs_label(self.crs)

    def pixel_size_m(self) -> tuple[float, float]:
        """(x, y) pixel size in metres at the raster centre (degrees via metres-per-degree)."""
        px, py = self.pixel_size
        if self.units.geographic:
            m_lat, m_lon = metres_per_degree(self.centre[1])
            return (px * m_lon, py * m_lat)
        return (px * self.units.xy_to_m, py * self.units.xy_to_m)

    def scaled(self, raw_to_z: np.ndarray) -> np.ndarray:
        """Apply band scale/offset and the vertical unit to heights (in place when float)."""
        z = raw_to_z
        if self.scale != 1.0:
            z *= self.scale
        if self.offset != 0.0:
            z += self.offset
        if self.units.z_to_m != 1.0:
            z *= self.units.z_to_m
        return z


# ------------------------------------------------------------------ CRS helpers
def crs_label(crs: Any) -> str | None:
    """``EPSG:nnnn`` for a CRS with an authority code, else WKT; None for no CRS."""
    if crs is None:
        return None
    code = crs.to_epsg()
    return f"EPSG:{code}" if code else crs.to_wkt()


def pyproj_crs(crs: Any) -> Any:
    """rasterio CRS -> pyproj CRS."""
    from pyproj import CRS

    return CRS.from_wkt(crs.to_wkt())


def horizontal_crs(crs: Any) -> Any:
    """The horizontal part (pyproj CRS) of a possibly compound CRS."""
    pc = pyproj_crs(crs)
    if pc.is_compound:
        return pc.sub_crs_list[0]
    return pc


def to_lonlat(crs: Any, x: Any, y: Any) -> tuple[Any, Any]:
    """Coordinates in ``crs`` (horizontal part) -> WGS84 (lon, lat) degrees."""
    from pyproj import Transformer

    tr = Transformer.from_crs(horizontal_crs(crs), "EPSG:4326", always_xy=True)
    return tr.transform(x, y)


def metres_per_degree(lat_deg: float) -> tuple[float, float]:
    """(m per degree latitude, m per degree longitude) at ``lat_deg`` on WGS84."""
    from vinecli.geo import GeoOrigin

    return GeoOrigin(lat_deg, 0.0, 0.0).metres_per_degree


def local_tm_crs(crs: Any, lat: float, lon: float) -> Any:
    """A local transverse Mercator (k=1, metres) centred at (lat, lon) on the datum of ``crs``.

    Used as the metric grid for geographic rasters; returns a rasterio CRS.
    """
    from pyproj.crs import ProjectedCRS
    from pyproj.crs.coordinate_operation import TransverseMercatorConversion
    from rasterio.crs import CRS

    geod = horizontal_crs(crs)
    conv = TransverseMercatorConversion(
        latitude_natural_origin=lat, longitude_natural_origin=lon, false_easting=0.0, false_northing=0.0,
        scale_factor_natural_origin=1.0,
    )
    tm = ProjectedCRS(conversion=conv, geodetic_crs=geod, name=f"Local TM at {lat:.6f} {lon:.6f}")
    return CRS.from_wkt(tm.to_wkt())


def placeholder_crs() -> Any:
    """A metric CRS used on both sides of a warp when the raster has no CRS (identity transform)."""
    from rasterio.crs import CRS

    return CRS.from_proj4("+proj=tmerc +lat_0=0 +lon_0=0 +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m +no_defs")


# ------------------------------------------------------------------ units
def detect_units(crs: Any, band_unit: str | None, z_unit: str | None = None,
                 path: Path | None = None) -> tuple[Units, list[str]]:
    """Horizontal and vertical units of a raster (see the module docstring for the order).

    Returns the units and a list of warnings for the user.
    """
    warnings: list[str] = []
    geographic = False
    xy_assumed = False
    vertical: tuple[str, float] | None = None
    if crs is None:
        xy_name, xy_to_m, xy_assumed = "metre", 1.0, True
        warnings.append("no CRS in the file: coordinates taken as metres; geodetic origin unknown")
    else:
        pc = pyproj_crs(crs)
        horiz = pc.sub_crs_list[0] if pc.is_compound else pc
        if horiz.is_geographic:
            xy_name, xy_to_m, geographic = "degree", 1.0, True
        else:
            axis = horiz.axis_info[0]
            xy_name, xy_to_m = axis.unit_name, float(axis.unit_conversion_factor)
        if pc.is_compound and len(pc.sub_crs_list) > 1 and pc.sub_crs_list[1].axis_info:
            ax = pc.sub_crs_list[1].axis_info[0]
            vertical = (ax.unit_name, float(ax.unit_conversion_factor))
        elif len(pc.axis_info) == 3:
            ax = pc.axis_info[2]
            vertical = (ax.unit_name, float(ax.unit_conversion_factor))
    if z_unit is not None:
        uf = unit_factor(z_unit)
        if uf is None:
            raise InputError(f"unknown vertical unit {z_unit!r} (choose from {', '.join(Z_UNIT_CHOICES)})", path=path)
        z_name, z_to_m, z_source = uf[0], uf[1], "option"
    elif unit_factor(band_unit) is not None:
        z_name, z_to_m = unit_factor(band_unit)  # type: ignore[misc]
        z_source = "band-unit"
    elif vertical is not None:
        z_name, z_to_m, z_source = vertical[0], vertical[1], "crs-vertical-axis"
    elif crs is not None and not geographic:
        z_name, z_to_m, z_source = xy_name, xy_to_m, "assumed-horizontal"
        if xy_to_m != 1.0:
            warnings.append(f"vertical unit not stated: heights taken as {xy_name} like the CRS (override with --z-unit)")
    else:
        z_name, z_to_m, z_source = "metre", 1.0, "assumed-metre"
    return Units(xy_name, xy_to_m, z_name, z_to_m, z_source, geographic, xy_assumed), warnings


# ------------------------------------------------------------------ opening and validating
def check_suffix(path: Path, allowed: tuple[str, ...] = RASTER_SUFFIXES) -> None:
    """InputError if ``path`` is not a regular file (a FIFO would block GDAL) or its extension is not one of
    ``allowed``; the DSM is noted as an input of the running command (:mod:`vinecli.inputs`)."""
    if path.suffix.lower() not in allowed:
        raise InputError(
            f"unknown extension {path.suffix or '(none)'!r}: expected a GeoTIFF DSM ({'/'.join(RASTER_SUFFIXES)})",
            path=path,
        )
    require_regular_file(path, "file")
    note_input(path, "DSM")


def check_out_dir(out: Path, *, overwrite: bool = False, inputs: Sequence[Path] = ()) -> None:
    """Fail early (OutputError, exit 2) if ``out`` cannot be written, before any heavy work.

    Same as :func:`vinecli.outputs.check_output_target` (probes writability for real; ``out`` may not
    equal or contain one of ``inputs``).
    """
    from vinecli.outputs import check_output_target

    check_output_target(Path(out), overwrite=overwrite, inputs=inputs, kind="terrain convert")


def read_format_json(directory: Path, kind: str, fmt: str) -> dict[str, Any]:
    """``directory/<kind>.json`` of a terrain output directory, checked to be format ``fmt``.

    InputError naming the file (or the directory when it is not a ``kind`` directory) otherwise.
    """

    js = directory / f"{kind}.json"
    if not js.is_file():
        raise InputError(f"not a {kind} directory (no {kind}.json)", path=directory)
    try:
        meta = read_input_json(js, f"{kind}.json")
    except InputError as exc:
        raise InputError(f"unreadable {kind}.json ({exc.problem})", path=js) from None
    if meta.get("format") != fmt:
        raise InputError(f"unknown {kind} format {meta.get('format')!r} (expected {fmt})", path=js)
    return meta


def _gdal_message(exc: BaseException) -> str:
    """The most specific GDAL message in an exception chain, on one line."""
    msgs = []
    e: BaseException | None = exc
    while e is not None:
        msgs.append(str(e))
        e = e.__cause__ or e.__context__
    msg = next((m for m in reversed(msgs) if m and "previous exception" not in m), msgs[0] if msgs else "")
    return " ".join(msg.split())


@contextmanager
def gdal_env() -> Iterator[None]:
    """rasterio.Env with a bounded GDAL block cache (peak memory stays near the arrays we hold)."""
    import rasterio

    with rasterio.Env(GDAL_CACHEMAX=GDAL_CACHE_MB, GDAL_NUM_THREADS=1):
        yield


@contextmanager
def open_raster(path: Path) -> Iterator[Any]:
    """Open ``path`` with rasterio; GDAL failures become :class:`TerrainError` naming the file."""
    import warnings

    import rasterio
    from rasterio.errors import NotGeoreferencedWarning, RasterioError

    path = Path(path)
    check_suffix(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NotGeoreferencedWarning)
            src = rasterio.open(path)
    except RasterioError as exc:
        raise TerrainError(f"not a readable GeoTIFF ({_gdal_message(exc)})", path=path) from exc
    try:
        yield src
    finally:
        src.close()


def check_dsm_size(width: int, height: int, path: Path) -> None:
    """TerrainError (exit 2) naming the limit and the raster's size when it has more than :data:`MAX_DSM_PX` pixels
    (every reader of a DSM reads each pixel at least once)."""
    if width * height > MAX_DSM_PX:
        raise TerrainError(f"raster is {width:,}x{height:,} px ({width * height / 1e9:.1f} Gpx): at most "
                           f"{MAX_DSM_PX / 1e9:g} Gpx (cut it to the field, or resample it coarser)", path=path)


def inspect_dsm(src: Any, *, z_unit: str | None = None) -> DsmMeta:
    """Validate an open dataset as a DSM and describe it (raises TerrainError naming the file)."""
    from rasterio.enums import MaskFlags
    from rasterio.errors import RasterioError
    from rasterio.windows import Window

    path = Path(src.name)
    if src.driver != "GTiff":
        raise TerrainError(f"not a GeoTIFF (GDAL reads it as {src.driver})", path=path)
    if src.count != 1:
        raise TerrainError(f"has {src.count} bands; a DSM must be a single-band elevation raster", path=path)
    dtype = np.dtype(src.dtypes[0])
    if dtype.kind not in "iuf":
        raise TerrainError(f"unsupported data type {dtype.name} (need integer or float heights)", path=path)
    t = src.transform
    if t.b != 0 or t.d != 0:
        raise TerrainError("rotated or skewed geotransform is not supported; warp it north-up first (gdalwarp)", path=path)
    if t.a <= 0 or t.e >= 0:
        raise TerrainError("geotransform is not north-up (need positive x and negative y pixel size)", path=path)
    if src.width < 2 or src.height < 2:
        raise TerrainError(f"raster is {src.width}x{src.height} px; need at least 2x2", path=path)
    check_dsm_size(src.width, src.height, path)
    try:  # a truncated file opens (header intact) but its last block is missing
        src.read(1, window=Window(src.width - 1, src.height - 1, 1, 1))
    except RasterioError as exc:
        raise TerrainError(f"truncated or corrupt GeoTIFF: pixel data unreadable ({_gdal_message(exc)})", path=path) from exc
    band_unit = src.units[0] if src.units else None
    units, warnings = detect_units(src.crs if src.crs else None, band_unit, z_unit, path)
    for w in warnings:
        log.warning("%s: %s", path.name, w)
    flags = src.mask_flag_enums[0]
    nodata = src.nodata
    block = src.block_shapes[0]
    return DsmMeta(
        path=path, width=src.width, height=src.height, dtype=dtype.name,
        nodata=None if nodata is None else float(nodata), transform=t, crs=src.crs if src.crs else None,
        units=units, scale=float(src.scales[0] or 1.0), offset=float(src.offsets[0] or 0.0),
        driver=src.driver, tiled=bool(src.profile.get("tiled", False)), block_shape=(int(block[0]), int(block[1])),
        compress=src.profile.get("compress"),
        has_dataset_mask=MaskFlags.per_dataset in flags or MaskFlags.alpha in flags, warnings=tuple(warnings),
    )


# ------------------------------------------------------------------ reading heights
def valid_mask(raw: np.ndarray, nodata: float | None) -> np.ndarray:
    """True where ``raw`` holds data: finite and != nodata, compared in the file's own dtype."""
    if raw.dtype.kind == "f":
        valid = np.isfinite(raw)
        if nodata is not None and math.isfinite(nodata):
            with np.errstate(over="ignore"):
                nd = np.asarray(nodata, dtype=np.float64).astype(raw.dtype)
            valid &= raw != nd
        return valid
    if nodata is not None and math.isfinite(nodata) and float(nodata).is_integer():
        info = np.iinfo(raw.dtype)
        if info.min <= nodata <= info.max:
            return raw != raw.dtype.type(int(nodata))
    return np.ones(raw.shape, dtype=bool)


def read_heights(src: Any, meta: DsmMeta, window: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """Read heights (float32 metres, NaN = nodata) and the valid mask for ``window`` (None = all).

    The nodata test runs on the native dtype before the float32 conversion.
    """
    from rasterio.errors import RasterioError

    try:
        raw = src.read(1, window=window)
        valid = valid_mask(raw, meta.nodata)
        if meta.has_dataset_mask:
            valid &= src.read_masks(1, window=window) > 0
    except RasterioError as exc:
        raise TerrainError(f"cannot read pixel data, truncated or corrupt? ({_gdal_message(exc)})", path=meta.path) from exc
    if raw.dtype == np.float64:
        z64 = np.where(valid, raw, np.nan)
        del raw
        z = meta.scaled(z64).astype(np.float32)
        del z64
    else:
        z = raw if raw.dtype == np.float32 else raw.astype(np.float32)
        del raw
        z[~valid] = np.nan
        z = meta.scaled(z)
    return z, valid


def scan_heights(src: Any, meta: DsmMeta) -> dict[str, float | int | None]:
    """Stream the whole band in windows of whole blocks: valid count, nodata share, z min/max (metres).

    Memory stays at one window (about :data:`SCAN_CHUNK_PX` pixels, one block when a block is larger) whatever
    the raster's size or shape: a window spans the full width only when a block row fits (a 10^6 px wide raster
    with 256-row blocks read in full-width strips held 1 GB).
    """
    from rasterio.windows import Window

    bh, bw = max(1, meta.block_shape[0]), max(1, meta.block_shape[1])
    cols = min(meta.width, max(bw, SCAN_CHUNK_PX // bh // bw * bw))
    rows = min(meta.height, max(bh, SCAN_CHUNK_PX // cols // bh * bh))
    n_valid = 0
    zmin, zmax = math.inf, -math.inf
    for r0 in range(0, meta.height, rows):
        for c0 in range(0, meta.width, cols):
            z, valid = read_heights(src, meta, Window(c0, r0, min(cols, meta.width - c0), min(rows, meta.height - r0)))
            k = int(valid.sum())
            if k:
                n_valid += k
                zmin = min(zmin, float(np.nanmin(z)))
                zmax = max(zmax, float(np.nanmax(z)))
    total = meta.width * meta.height
    return {
        "valid": n_valid,
        "total": total,
        "nodata_fraction": 1.0 - n_valid / total,
        "z_min": zmin if n_valid else None,
        "z_max": zmax if n_valid else None,
    }
