"""Earth magnetic field at the world's geodetic origin from the World Magnetic Model.

Uses ``pygeomag`` (a port of NOAA's WMM; WMM-2025 coefficients by default, valid 2025-2030).
PX4 compares the simulated field with its own WMM tables (strength, inclination,
declination) before arming, so the simulator must report the real field of the location
(docs/firmware-protocols.md §2). Results are cached: pygeomag costs milliseconds per call.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import lru_cache

from vinecli.frames import Vec3
from vinecli.geo import GeoOrigin

#: decimal year used when none is given: a fixed epoch keeps runs reproducible
DEFAULT_YEAR = 2026.0
NT_PER_GAUSS = 1e5

__all__ = ["DEFAULT_YEAR", "MagneticField", "earth_field", "earth_field_ned", "earth_field_world"]


@dataclass(frozen=True)
class MagneticField:
    """The WMM field at one place and time."""

    ned_gauss: Vec3  # north, east, down components, gauss
    intensity_gauss: float  # |B|, gauss
    inclination_deg: float  # dip, positive downwards (northern hemisphere)
    declination_deg: float  # east of true north


@lru_cache(maxsize=64)
def _calc(lat: float, lon: float, alt_m: float, year: float, coefficients_file: str | None) -> MagneticField:
    from pygeomag import GeoMag

    gm = GeoMag(coefficients_file=coefficients_file) if coefficients_file else GeoMag()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = gm.calculate(glat=lat, glon=lon, alt=alt_m / 1000.0, time=year, allow_date_outside_lifespan=True)
    k = 1.0 / NT_PER_GAUSS
    return MagneticField((r.x * k, r.y * k, r.z * k), r.f * k, r.i, r.d)


def earth_field(origin: GeoOrigin, year: float | None = None, *, coefficients_file: str | None = None) -> MagneticField:
    """WMM field at ``origin`` (lat, lon deg; alt m) for a decimal ``year`` (default :data:`DEFAULT_YEAR`).

    ``coefficients_file`` selects another pygeomag model, e.g. ``"wmm/WMM_2020.COF"``.
    """
    y = DEFAULT_YEAR if year is None else float(year)
    return _calc(float(origin.lat), float(origin.lon), float(origin.alt), y, coefficients_file)


def earth_field_ned(origin: GeoOrigin, year: float | None = None, *, coefficients_file: str | None = None) -> Vec3:
    """Earth field (north, east, down) in gauss at ``origin`` from the WMM."""
    return earth_field(origin, year, coefficients_file=coefficients_file).ned_gauss


def earth_field_world(origin: GeoOrigin, year: float | None = None) -> Vec3:
    """Earth field in the world frame (ENU along the world's grid: the true-ENU field rotated by the grid
    convergence, :func:`vinecli.frames.true_enu_to_grid`), gauss: what a magnetometer in the world measures."""
    from vinecli.frames import ned_to_enu, true_enu_to_grid

    return true_enu_to_grid(ned_to_enu(earth_field_ned(origin, year)), origin.convergence_rad)
