"""Prescription maps from the grower -> application rates (L/ha of ground) in a world's local frame; docs/dose.md.

Accepted: zones (GeoJSON, Shapefile, GeoPackage, KML: polygons with a numeric rate column, any CRS) with a
default rate outside them; a GeoTIFF rate raster (band 1, any CRS, nodata = no prescription there); ISO 11783-10
TaskData (a ``TASKDATA.XML`` or its folder: treatment-zone polygons, grids of type 1 and 2,
:mod:`vinecli.gis.isoxml_read`). Rates may be in L/ha (default), gal/ac (US) or mL/m² (``units``; a raster's
band unit, when set, must be one of them).

Every map is checked against the field before it is used (InputError, exit 2, one line naming the file): the
file must read; the rate column must exist and hold numbers; rates must be 0 (no spray) or within
[:data:`MIN_RATE_LPHA`, :data:`MAX_RATE_LPHA`]; the map must overlap the rows; rows outside the map need a
default rate. The map is read, never written.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vinecli.errors import InputError
from vinecli.gis.georef import Georef
from vinecli.gis.rate_map import MAX_RATE_LPHA, MIN_RATE_LPHA, RateMap, check_rate, to_lpha

__all__ = ["read_prescription"]

Polyline = Sequence[tuple[float, float]]


def read_prescription(path: Path | str, georef: Georef, rows: Sequence[Polyline], *, column: str | None = None,
                      default_lpha: float | None = None, layer: str | None = None, units: str = "L/ha") -> RateMap:
    """The prescription at ``path`` checked against the field's ``rows`` (local m); see the module docstring."""
    path = Path(path)
    if path.is_dir() or path.name.upper() == "TASKDATA.XML" or path.suffix.lower() == ".xml":
        from vinecli.gis.isoxml_read import read_isoxml

        m = read_isoxml(path, georef)
        if m.default_lpha is None:
            m.default_lpha = default_lpha
    elif path.suffix.lower() in (".tif", ".tiff"):
        m = _read_raster(path, georef, units)
        m.default_lpha = default_lpha
    else:
        m = _read_zones(path, georef, column, layer, units)
        m.default_lpha = default_lpha
    if default_lpha is not None:
        check_rate(default_lpha, "default rate", path)
    _check_field(m, rows)
    return m


def _read_zones(path: Path, georef: Georef, column: str | None, layer: str | None, units: str) -> RateMap:
    from vinecli.gis.read import read_features

    if not column:
        raise InputError("zones need a rate column (--rate-column / prescription.column)", path=path)
    f = to_lpha(units, path)
    feats = read_features(path, georef, expect="polygons", layer=layer)
    if column not in feats[0].properties:
        cols = ", ".join(sorted(feats[0].properties)) or "none"
        raise InputError(f"layer {feats[0].layer!r}: no rate column {column!r} (columns: {cols})", path=path)
    zones = []
    for ft in feats:
        v = ft.properties.get(column)
        where = f"layer {ft.layer!r} feature {ft.fid} column {column!r}"
        try:
            rate = float(v) if not isinstance(v, bool) and v is not None else math.nan
        except (TypeError, ValueError):
            raise InputError(f"{where}: {v!r} is not a number", path=path) from None
        if not math.isfinite(rate):
            raise InputError(f"{where}: {v!r} is not a number", path=path)
        rate = check_rate(rate * f, where, path)
        zones += [(ring, rate, str(ft.properties.get("name", ft.fid)), holes)
                  for ring, holes in zip(ft.parts, ft.holes, strict=True)]
    return RateMap(path, "zones", georef, zones=zones, notes=[f"{len(feats)} zones, column {column!r} in {units}"])


def _read_raster(path: Path, georef: Georef, units: str) -> RateMap:
    import rasterio

    try:
        with rasterio.open(path) as ds:
            if ds.crs is None:
                raise InputError("rate raster has no CRS", path=path)
            band_units = (ds.units or (None,))[0]
            values = ds.read(1, masked=True).astype(np.float64).filled(np.nan)
            to_pixel, crs = ~ds.transform, ds.crs
    except rasterio.errors.RasterioError as exc:
        raise InputError(f"cannot read rate raster: {exc}", path=path) from None
    f = to_lpha(band_units or units, path)
    values = values * f
    finite = values[np.isfinite(values)]
    if finite.size:
        bad = finite[(finite < 0) | (finite > MAX_RATE_LPHA) | ((finite > 0) & (finite < MIN_RATE_LPHA))]
        if bad.size:
            check_rate(float(bad[0]), f"band 1 ({bad.size} cells)", path)
    return RateMap(path, "raster", georef, grid=values, to_pixel=to_pixel, grid_crs=crs,
                   notes=[f"{values.shape[1]} x {values.shape[0]} cells in {band_units or units}"])


def _check_field(m: RateMap, rows: Sequence[Polyline]) -> None:
    """The map overlaps the rows, and rows outside it have a default rate (InputError otherwise)."""
    from vinecli.rows.canopy_segments import row_stations

    xs, ys, step = [], [], 0.5
    for r in rows:
        total = float(np.sum(np.hypot(*np.diff(np.asarray(r, dtype=np.float64), axis=0).T))) if len(r) >= 2 else 0.0
        if total > 0:
            p, _ = row_stations(r, np.arange(0.0, total + 1e-9, step))
            xs.append(p[:, 0])
            ys.append(p[:, 1])
    if not xs:
        raise InputError("no rows to apply the prescription to", path=m.path)
    mapped = m.mapped(np.concatenate(xs), np.concatenate(ys))
    inside = np.isfinite(mapped)
    if not inside.any():
        raise InputError("no overlap with the field: the map prescribes nothing along any row (wrong CRS or "
                         "another field?)", path=m.path)
    if m.default_lpha is None and not inside.all():
        raise InputError(f"{(~inside).sum() * step:.1f} m of rows lie outside the map: give a default rate "
                         "(--default-rate / prescription.default_lpha)", path=m.path)
    out = (~inside).sum() * step
    if out > 0:
        m.notes.append(f"{out:.1f} m of rows outside the map at the default rate {m.default_lpha:g} L/ha")
