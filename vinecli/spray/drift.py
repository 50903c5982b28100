"""Where the ground deposit lies relative to the field: in it, beyond it, beyond the drift domain, and the
sedimenting drift curve downwind of the last row (ISO 22866 style). Plain numpy + shapely, world ENU, m.

The field is the area of the vine rows: the convex hull of every row polyline grown by half the row
spacing on each side (flat caps), so the inter-rows and the half inter-row beyond the outer rows
belong to it (a field that is not convex, e.g. L-shaped, counts its hull). Without rows it is the
hull of the sprayed path grown by the median spray-cone radius. The drift domain is the
field grown by ``domain_m``; liquid that lands beyond it crossed the domain's boundary airborne.

Each parcel lands uniformly over a disc (its spray cone); the share of the disc on either side of
a boundary is taken across the boundary's nearest straight edge, i.e. the semicircle law of the
disc's cross-section at the centre's signed distance (exact for straight edges, the corners of
the field aside).

Drift curve: the deposit per ground area, as % of the rate applied in the field, in 1 m wide bands
parallel to the last row downwind (the outermost row on the side the crosswind blows to) at the
given distances from that row's line, over the central half of its length (ISO 22866 lays its
collectors in the middle of the field's downwind edge). In calm air (crosswind < 0.1 m/s) both
sides are averaged.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vinecli.geometry import Polyline, convex_signed_distance
from vinecli.spray.interception import semicircle_cdf

__all__ = ["CALM_MPS", "DriftFrame", "drift_curve", "drift_frames", "field_polygon", "field_split"]

CALM_MPS = 0.1


def field_polygon(rows: Sequence[Polyline], spacing_m: float, path_xy: np.ndarray, cone_radius_m: float) -> object:
    """The field as a convex shapely polygon (see the module doc), or None with nothing to span."""
    import shapely
    from shapely.geometry import LineString, MultiLineString, MultiPoint

    lines = [LineString(r) for r in rows if len(r) >= 2]
    if lines:
        half = 0.5 * spacing_m if math.isfinite(spacing_m) and spacing_m > 0 else 1.0
        geom = MultiLineString(lines).buffer(half, cap_style="flat", join_style="mitre")
    elif len(path_xy) >= 2:
        geom = LineString(path_xy).buffer(max(cone_radius_m, 0.5), cap_style="flat")
    elif len(path_xy) == 1:
        geom = shapely.Point(path_xy[0]).buffer(max(cone_radius_m, 0.5))
    else:
        return None
    return MultiPoint(shapely.get_coordinates(geom)).convex_hull


def field_split(field: object, domain_m: float, x: np.ndarray, y: np.ndarray, radius: np.ndarray,
                vol: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per parcel: volume landing (in the field, beyond it within the domain, beyond the domain), L."""
    if field is None or vol.size == 0:
        z = np.zeros_like(vol)
        return vol.copy(), z, z
    import shapely

    ring = np.asarray(shapely.get_coordinates(field.exterior), dtype=np.float64)  # type: ignore[attr-defined]
    d = convex_signed_distance(ring, x, y)
    r = np.maximum(radius, 1e-3)
    inside = semicircle_cdf(-d / r)
    within_domain = semicircle_cdf((domain_m - d) / r)
    beyond = vol * (1.0 - within_domain)
    infield = vol * inside
    return infield, vol - infield - beyond, beyond


@dataclass(frozen=True)
class DriftFrame:
    """A downwind edge: origin on the last row's line (m ENU), unit normal pointing downwind, unit tangent,
    and the along-edge stretch (m from the origin) the curve averages over."""

    origin: tuple[float, float]
    normal: tuple[float, float]
    tangent: tuple[float, float]
    along: tuple[float, float]
    row: int | None


def _row_direction(rows: Sequence[Polyline]) -> np.ndarray:
    acc = np.zeros(2)
    ref = None
    for r in rows:
        p = np.asarray(r, dtype=float)
        if len(p) < 2:
            continue
        d = p[-1] - p[0]
        if ref is None:
            ref = d
        acc += d if float(np.dot(d, ref)) >= 0 else -d
    n = float(np.linalg.norm(acc))
    return acc / n if n > 0 else np.array([0.0, 1.0])


def drift_frames(rows: Sequence[Polyline], field: object, wind_xy: tuple[float, float],
                 central_share: float = 0.5) -> tuple[list[DriftFrame], bool]:
    """The downwind edge frame(s) and whether the air was calm (then both sides, to be averaged)."""
    rows = [r for r in rows if len(r) >= 2]
    w = np.asarray(wind_xy, dtype=float)
    if rows:
        t = _row_direction(rows)
        n = np.array([t[1], -t[0]])
        cross = float(np.dot(w, n))
    else:
        speed = float(np.hypot(*w))
        n = w / speed if speed > CALM_MPS else np.array([1.0, 0.0])
        t = np.array([-n[1], n[0]])
        cross = speed
    calm = abs(cross) < CALM_MPS
    signs = (1.0, -1.0) if calm else ((1.0,) if cross >= 0 else (-1.0,))
    frames = []
    for sg in signs:
        nn, tt = n * sg, t
        if rows:
            mids = [np.mean(np.asarray(r, dtype=float), axis=0) for r in rows]
            i = int(np.argmax([float(np.dot(m, nn)) for m in mids]))
            p = np.asarray(rows[i], dtype=float)
            origin = mids[i]
            a = (p - origin) @ tt
        else:
            if field is None:
                continue
            import shapely

            xy = np.asarray(shapely.get_coordinates(field), dtype=float)
            i_edge = int(np.argmax(xy @ nn))
            origin = xy[i_edge] - tt * float((xy[i_edge] - xy.mean(axis=0)) @ tt)
            a = (xy - origin) @ tt
            i = None
        a0, a1 = float(a.min()), float(a.max())
        trim = 0.5 * (1.0 - central_share) * (a1 - a0)
        frames.append(DriftFrame((float(origin[0]), float(origin[1])), (float(nn[0]), float(nn[1])),
                                 (float(tt[0]), float(tt[1])), (a0 + trim, a1 - trim), i))
    return frames, calm


def drift_curve(frames: Sequence[DriftFrame], x: np.ndarray, y: np.ndarray, radius: np.ndarray, vol: np.ndarray,
                applied_lpha: float, distances_m: Sequence[float], band_m: float = 1.0) -> list[dict[str, float]]:
    """``[{distance_m, percent_of_applied}]``: ground deposit in a ``band_m`` wide band centred at each distance
    from the last row's line downwind, per ground area, over the applied rate, averaged over ``frames``."""
    out = []
    applied = applied_lpha / 1e4  # L/m²
    r = np.maximum(radius, 1e-3)
    for dist in distances_m:
        vals = []
        for f in frames:
            s = (x - f.origin[0]) * f.normal[0] + (y - f.origin[1]) * f.normal[1]
            a = (x - f.origin[0]) * f.tangent[0] + (y - f.origin[1]) * f.tangent[1]
            length = f.along[1] - f.along[0]
            if length <= 0 or not applied > 0:
                continue
            sel = (a >= f.along[0]) & (a <= f.along[1])
            d0, d1 = dist - 0.5 * band_m, dist + 0.5 * band_m
            mass = vol[sel] * (semicircle_cdf((d1 - s[sel]) / r[sel]) - semicircle_cdf((d0 - s[sel]) / r[sel]))
            vals.append(float(mass.sum()) / (band_m * length) / applied * 100.0)
        out.append({"distance_m": float(dist), "percent_of_applied": float(np.mean(vals)) if vals else math.nan})
    return out
