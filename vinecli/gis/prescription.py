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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError
from vinecli.gis.georef import Georef

__all__ = ["MAX_RATE_LPHA", "MIN_RATE_LPHA", "UNITS_LPHA", "RateMap", "check_rate", "read_prescription",
           "to_lpha"]

#: a prescribed rate above this is absurd (the mission's own limit for rate_lpha), L/ha
MAX_RATE_LPHA = 10_000.0
#: a rate above 0 but below this is a unit mistake (ULV sprays start near 1 L/ha), L/ha
MIN_RATE_LPHA = 0.1
#: accepted rate units -> L/ha per unit (US gallon 3.785411784 L, acre 0.40468564224 ha)
UNITS_LPHA = {"l/ha": 1.0, "gal/ac": 3.785411784 / 0.40468564224, "ml/m2": 10.0, "ml/m²": 10.0}

Polyline = Sequence[tuple[float, float]]


def to_lpha(units: str, path: Path) -> float:
    """L/ha per unit of ``units``; InputError for units vinecli does not know."""
    f = UNITS_LPHA.get(units.strip().lower().replace(" ", ""))
    if f is None:
        raise InputError(f"unknown rate units {units!r} (use {', '.join(sorted({'L/ha', 'gal/ac', 'mL/m2'}))})",
                         path=path)
    return f


def check_rate(rate: float, where: str, path: Path) -> float:
    """``rate`` (L/ha) when finite and 0 or within [MIN, MAX]; else InputError naming ``where``."""
    if not math.isfinite(rate):
        raise InputError(f"{where}: rate is not a number", path=path)
    if rate < 0:
        raise InputError(f"{where}: negative rate {rate:g} L/ha", path=path)
    if rate > MAX_RATE_LPHA or 0 < rate < MIN_RATE_LPHA:
        raise InputError(f"{where}: absurd rate {rate:g} L/ha (use 0 or {MIN_RATE_LPHA:g}-{MAX_RATE_LPHA:g} L/ha: "
                         "wrong units?)", path=path)
    return rate


@dataclass
class RateMap:
    """A prescription in local metres. Zones: ``zones`` [(ring, rate L/ha, name)] (the first containing a point
    wins); a grid: ``grid`` values (ny, nx) L/ha (NaN: none) with ``to_pixel`` (CRS x, y -> col, row, float) in
    ``grid_crs``. ``default_lpha``: the rate where the map prescribes nothing (None: none given)."""

    path: Path
    kind: str
    georef: Georef
    default_lpha: float | None = None
    zones: list[tuple[list[tuple[float, float]], float, str]] = field(default_factory=list)
    grid: np.ndarray | None = None
    to_pixel: Any = None
    grid_crs: Any = None
    notes: list[str] = field(default_factory=list)

    def mapped(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The map's own rate at local points, L/ha; NaN where it prescribes nothing."""
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        out = np.full(x.shape, np.nan)
        if self.zones:
            import shapely
            from shapely.geometry import Polygon

            for ring, rate, _ in reversed(self.zones):  # the first zone containing a point wins
                out[shapely.contains_xy(Polygon(ring), x, y)] = rate
        if self.grid is not None:
            pts = self.georef.to_crs(list(zip(x.tolist(), y.tolist(), strict=True)), self.grid_crs) if x.size else []
            cr = np.array([self.to_pixel * p for p in pts]).reshape(-1, 2)
            col, row = np.floor(cr[:, 0]).astype(int), np.floor(cr[:, 1]).astype(int)
            ny, nx = self.grid.shape
            ok = (col >= 0) & (col < nx) & (row >= 0) & (row < ny)
            out[ok] = self.grid[row[ok], col[ok]]
        return out

    def rates(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The prescribed rate at local points, L/ha: the map's, else the default (NaN without one)."""
        r = self.mapped(x, y)
        if self.default_lpha is not None:
            r[np.isnan(r)] = self.default_lpha
        return r

    def summary(self) -> dict[str, Any]:
        vals = [z[1] for z in self.zones] if self.zones else (
            self.grid[np.isfinite(self.grid)].tolist() if self.grid is not None else [])
        return {"file": str(self.path), "kind": self.kind, "zones": len(self.zones) or None,
                "cells": int(self.grid.size) if self.grid is not None else None,
                "rate_min_lpha": min(vals, default=math.nan), "rate_max_lpha": max(vals, default=math.nan),
                "default_lpha": self.default_lpha, "notes": list(self.notes)}


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
        zones += [(ring, rate, str(ft.properties.get("name", ft.fid))) for ring in ft.parts]
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
