"""Geodesy: the world's geodetic origin and world <-> latitude/longitude/altitude.

A world without a CRS is the topocentric ENU frame (metres) tangent to the WGS84 ellipsoid at
:class:`GeoOrigin`. A world built from a DSM with a CRS is laid out on the CRS grid (docs/architecture.md
"Frames"): :class:`GeoFrame` maps it through the CRS, exactly (pyproj) for files and by a quadratic fit for the
per-step paths, and knows the grid convergence (the world's axes against true east/north) that the firmware
boundary rotates headings by. Altitudes are metres above mean sea level as given by the terrain's vertical datum;
the local frame treats them as ellipsoidal heights (a constant offset of tens of metres at most, irrelevant at
field scale).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

from vinecli.frames import Vec3


@dataclass(frozen=True)
class GeoOrigin:
    """Geodetic origin of the local ENU frame: latitude, longitude (deg, WGS84), altitude (m)."""

    lat: float
    lon: float
    alt: float

    def to_dict(self) -> dict[str, float]:
        """JSON form ``{"lat": .., "lon": .., "alt": ..}``."""
        return {"lat": self.lat, "lon": self.lon, "alt": self.alt}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> GeoOrigin:
        """Inverse of :meth:`to_dict`."""
        return cls(float(d["lat"]), float(d["lon"]), float(d["alt"]))

    @cached_property
    def _pipeline(self) -> Any:
        from pyproj import Transformer

        return Transformer.from_pipeline(
            "+proj=pipeline +step +proj=axisswap +order=2,1 +step +proj=unitconvert +xy_in=deg +xy_out=rad "
            f"+step +proj=cart +ellps=WGS84 +step +proj=topocentric +ellps=WGS84 "
            f"+lat_0={self.lat!r} +lon_0={self.lon!r} +h_0={self.alt!r}"
        )

    def geodetic_to_enu(self, lat: float, lon: float, alt: float) -> Vec3:
        """(lat deg, lon deg, alt m) -> local ENU (m)."""
        e, n, u = self._pipeline.transform(lat, lon, alt)
        return (float(e), float(n), float(u))

    def enu_to_geodetic(self, e: float, n: float, u: float) -> Vec3:
        """Local ENU (m) -> (lat deg, lon deg, alt m)."""
        from pyproj.enums import TransformDirection

        lat, lon, alt = self._pipeline.transform(e, n, u, direction=TransformDirection.INVERSE)
        return (float(lat), float(lon), float(alt))

    def enu_to_geodetic_fast(self, e: float, n: float, u: float) -> Vec3:
        """Local ENU -> geodetic by the local-tangent approximation (error ~ d^2 tan(lat) / R: 2 mm at 100 m).

        Used at sensor rates in the simulation loop, where a pyproj call per sample costs ~30 µs.
        """
        m_lat, m_lon = self.metres_per_degree
        return (self.lat + n / m_lat, self.lon + e / m_lon, self.alt + u)

    def geodetic_to_enu_fast(self, lat: float, lon: float, alt: float) -> Vec3:
        """Inverse of :meth:`enu_to_geodetic_fast` (plain floats: the estimator's GNSS fixes, MAVLink items)."""
        m_lat, m_lon = self.metres_per_degree
        return ((lon - self.lon) * m_lon, (lat - self.lat) * m_lat, alt - self.alt)

    @property
    def convergence_rad(self) -> float:
        """Angle (rad, counter-clockwise) from true east to the world's x axis: 0 for the topocentric frame."""
        return 0.0

    @cached_property
    def metres_per_degree(self) -> tuple[float, float]:
        """(m per degree latitude, m per degree longitude) at the origin (WGS84 radii of curvature)."""
        a, f = 6378137.0, 1 / 298.257223563
        e2 = f * (2 - f)
        phi = math.radians(self.lat)
        s = math.sin(phi)
        n_radius = a / math.sqrt(1 - e2 * s * s)
        m_radius = a * (1 - e2) / (1 - e2 * s * s) ** 1.5
        return (math.radians(1) * (m_radius + self.alt), math.radians(1) * (n_radius + self.alt) * math.cos(phi))


#: half-width (m) of the square about the world origin the per-step quadratic is fitted over
_FIT_HALF_M = 500.0


@dataclass(frozen=True)
class GeoFrame(GeoOrigin):
    """A world on a CRS grid: world (x, y) m = ((X - cx) * sx + ox, (Y - cy) * sy + oy) for CRS coordinates
    (X, Y) (``crs``, ``crs_centre`` (cx, cy), ``m_per_unit`` (sx, sy), ``offset`` (ox, oy): the terrain's
    :class:`~vinecli.rows.source.RowFrame`); ``lat``, ``lon``, ``alt`` are the world's recorded origin (``alt`` is
    the height of world z = 0). Files go through the CRS exactly (:meth:`enu_to_geodetic`); the per-step paths
    through a quadratic fitted to it over +-500 m (error below 0.1 mm there)."""

    crs: str = "EPSG:4326"
    crs_centre: tuple[float, float] = (0.0, 0.0)
    m_per_unit: tuple[float, float] = (1.0, 1.0)
    offset: tuple[float, float] = (0.0, 0.0)

    @cached_property
    def _transformers(self) -> tuple[Any, Any]:
        from pyproj import CRS, Transformer

        c = CRS.from_user_input(self.crs)
        c = c.sub_crs_list[0] if c.is_compound else c
        return (Transformer.from_crs(c, "EPSG:4326", always_xy=True),
                Transformer.from_crs("EPSG:4326", c, always_xy=True))

    def enu_to_geodetic(self, e: float, n: float, u: float) -> Vec3:
        """World (x, y, z) m -> (lat deg, lon deg, alt m) through the CRS."""
        (cx, cy), (sx, sy), (ox, oy) = self.crs_centre, self.m_per_unit, self.offset
        lon, lat = self._transformers[0].transform((e - ox) / sx + cx, (n - oy) / sy + cy)
        return (float(lat), float(lon), self.alt + u)

    def geodetic_to_enu(self, lat: float, lon: float, alt: float) -> Vec3:
        """(lat deg, lon deg, alt m) -> world (x, y, z) m through the CRS."""
        (cx, cy), (sx, sy), (ox, oy) = self.crs_centre, self.m_per_unit, self.offset
        x, y = self._transformers[1].transform(lon, lat)
        return ((float(x) - cx) * sx + ox, (float(y) - cy) * sy + oy, alt - self.alt)

    @cached_property
    def _fits(self) -> tuple[tuple[float, ...], ...]:
        """Quadratic coefficients [1, a, b, a^2, ab, b^2]: (lat, lon) of world (x, y) about (lat0, lon0), and world
        (x, y) of true metres (a, b) = ((lon - lon0) m_lon, (lat - lat0) m_lat)."""
        import numpy as np

        g = np.linspace(-_FIT_HALF_M, _FIT_HALF_M, 9)
        xs, ys = (a.ravel() for a in np.meshgrid(g, g))
        ll = np.array([self.enu_to_geodetic(float(x), float(y), 0.0)[:2] for x, y in zip(xs, ys, strict=True)])
        dlat, dlon = ll[:, 0] - self.lat, ll[:, 1] - self.lon
        m_lat, m_lon = self.metres_per_degree

        def fit(a: Any, b: Any, v: Any) -> tuple[float, ...]:
            basis = np.column_stack([np.ones_like(a), a, b, a * a, a * b, b * b])
            return tuple(float(c) for c in np.linalg.lstsq(basis, v, rcond=None)[0])

        return (fit(xs, ys, dlat), fit(xs, ys, dlon), fit(dlon * m_lon, dlat * m_lat, xs),
                fit(dlon * m_lon, dlat * m_lat, ys))

    def enu_to_geodetic_fast(self, e: float, n: float, u: float) -> Vec3:
        """World -> geodetic by the quadratic fit (plain floats)."""
        f = self._fits
        return (self.lat + _quad(f[0], e, n), self.lon + _quad(f[1], e, n), self.alt + u)

    def geodetic_to_enu_fast(self, lat: float, lon: float, alt: float) -> Vec3:
        """Geodetic -> world by the quadratic fit (plain floats)."""
        m_lat, m_lon = self.metres_per_degree
        a, b = (lon - self.lon) * m_lon, (lat - self.lat) * m_lat
        f = self._fits
        return (_quad(f[2], a, b), _quad(f[3], a, b), alt - self.alt)

    @cached_property
    def convergence_rad(self) -> float:  # type: ignore[override]
        """Angle (rad, counter-clockwise) from true east to the world's x axis (the grid convergence: +1.770 deg
        at the sample field, west of UTM 16N's central meridian)."""
        m_lat, m_lon = self.metres_per_degree
        f = self._fits
        return math.atan2(f[0][1] * m_lat, f[1][1] * m_lon)


def _quad(c: tuple[float, ...], a: float, b: float) -> float:
    return c[0] + c[1] * a + c[2] * b + c[3] * a * a + c[4] * a * b + c[5] * b * b
