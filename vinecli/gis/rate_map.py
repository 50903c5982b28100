"""A prescription map in a world's local frame (:class:`RateMap`) and the bounds of a sane rate; docs/dose.md.
Read by :mod:`vinecli.gis.prescription` (zones, rasters) and :mod:`vinecli.gis.isoxml_read` (ISO-XML)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError
from vinecli.gis.georef import Georef

__all__ = ["MAX_RATE_LPHA", "MIN_RATE_LPHA", "UNITS_LPHA", "RateMap", "check_rate", "to_lpha"]

#: a prescribed rate above this is absurd (the mission's own limit for rate_lpha), L/ha
MAX_RATE_LPHA = 10_000.0
#: a rate above 0 but below this is a unit mistake (ULV sprays start near 1 L/ha), L/ha
MIN_RATE_LPHA = 0.1
#: accepted rate units -> L/ha per unit (US gallon 3.785411784 L, acre 0.40468564224 ha)
UNITS_LPHA = {"l/ha": 1.0, "gal/ac": 3.785411784 / 0.40468564224, "ml/m2": 10.0, "ml/m²": 10.0}



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
    """A prescription in local metres. Zones: ``zones`` [(ring, rate L/ha, name, holes)] (the first containing a
    point wins; not in its holes); a grid: ``grid`` values (ny, nx) L/ha (NaN: none) with ``to_pixel`` (CRS x, y -> col, row, float) in
    ``grid_crs``. ``default_lpha``: the rate where the map prescribes nothing (None: none given)."""

    path: Path
    kind: str
    georef: Georef
    default_lpha: float | None = None
    zones: list[tuple[list[tuple[float, float]], float, str, list[list[tuple[float, float]]]]] = \
        field(default_factory=list)
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

            for ring, rate, _, holes in reversed(self.zones):  # the first zone containing a point wins
                out[shapely.contains_xy(Polygon(ring, holes), x, y)] = rate
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
