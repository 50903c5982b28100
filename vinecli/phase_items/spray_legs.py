"""Spray legs -> mission waypoints: terrain-following waypoints, sprayer on over the rows only.

Heights: waypoints are MAV_FRAME_GLOBAL_RELATIVE_ALT (above home). With a ``surface`` (ENU z of the DSM
surface, i.e. the canopy tops), each leg is sampled every 0.5 m, the surface is lifted to its running
maximum over +-1 m (the spray height is kept above the canopy, not into its gaps): the height wanted is
``surface + height - home surface``. A firmware flies a mission leg by leg and slows down at every
waypoint where its path bends (up or down too) and on short legs (PX4's and ArduPilot's jerk-limited
trajectories; measured: both slowed to 0.5-0.7 m/s over a 0.3 m canopy bump between waypoints 1.5 m
apart, PX4's constant flow then over-doses there 2.3x and AC_Sprayer stops below its minimum speed). So the
waypoints are at least ``min_leg_m`` apart (besides the legs' own vertices) and each straight leg between
them is lifted until no point of it is more than 0.1 m below the height wanted: the path is a few long
straight legs that clear the canopy (higher over a bump, never lower); a waypoint on the straight line of
its neighbours is dropped, so flat ground gives none.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from vinecli.rows.plan import Leg

__all__ = ["SprayAction", "leg_actions"]

#: ("wp", x, y, alt above home m) or ("spray", flow L/s, 0, 0)
SprayAction = tuple[str, float, float, float]

_SAMPLE_M, _LIFT_M, _CLEAR_M = 0.5, 1.0, 0.1
#: shortest leg between terrain-following waypoints on one straight line, m (module docstring)
MIN_LEG_M = 6.0


def _knots(cum: np.ndarray, ds: np.ndarray, min_leg: float) -> list[int]:
    """Sample indices of the waypoints: the polyline's vertices (cumulative distances ``cum``) and, between
    them, points splitting each straight piece into equal legs of at least ``min_leg`` (one leg if shorter)."""
    at: list[float] = []
    for a, b in zip(cum[:-1], cum[1:], strict=True):
        k = max(1, int((b - a) // min_leg))
        at += [a + (b - a) * j / k for j in range(k)]
    at.append(float(cum[-1]))
    return sorted({int(np.argmin(np.abs(ds - d))) for d in at})


def _profile(points: Sequence[tuple[float, float]], surface: Callable[[float, float], float], height: float,
             home_z: float, min_leg: float = MIN_LEG_M) -> list[tuple[float, float, float]]:
    """Terrain-following waypoints (x, y, alt above home) along a polyline (see the module docstring)."""
    from scipy.ndimage import maximum_filter1d
    from shapely.geometry import LineString

    line = LineString(points)
    if line.length < 1e-6:
        return [(float(x), float(y), round(surface(x, y) + height - home_z, 3)) for x, y in points[:1]]
    n = max(2, int(math.ceil(line.length / _SAMPLE_M)) + 1)
    ds = np.linspace(0.0, line.length, n)
    xy = np.array([(p.x, p.y) for p in (line.interpolate(d) for d in ds)])
    z = np.array([surface(float(x), float(y)) for x, y in xy])
    need = maximum_filter1d(z, max(1, int(round(2 * _LIFT_M / (ds[1] - ds[0])))) + 1) + height - home_z
    cum = np.concatenate([[0.0], np.cumsum([math.dist(a, b) for a, b in zip(points[:-1], points[1:], strict=True)])])
    vertices = {int(np.argmin(np.abs(ds - c))) for c in cum}
    ki = _knots(cum, ds, min_leg)
    alt = need[ki].astype(float)
    for j in range(len(ki) - 1):  # lifting a leg's ends never brings another leg lower: one sweep clears all
        i0, i1 = ki[j], ki[j + 1]
        short = float(np.max(need[i0:i1 + 1] - np.interp(ds[i0:i1 + 1], [ds[i0], ds[i1]], [alt[j], alt[j + 1]])))
        if short > _CLEAR_M:
            alt[j] += short - _CLEAR_M
            alt[j + 1] += short - _CLEAR_M
    keep = [0]
    for j in range(1, len(ki) - 1):  # drop a waypoint (not a vertex) on the straight line of its neighbours
        a, b = keep[-1], j + 1
        on_line = np.interp(ds[ki[j]], [ds[ki[a]], ds[ki[b]]], [alt[a], alt[b]])
        if ki[j] in vertices or abs(alt[j] - on_line) > 0.02:
            keep.append(j)
    keep.append(len(ki) - 1)
    return [(float(xy[ki[j], 0]), float(xy[ki[j], 1]), round(float(alt[j]), 3)) for j in keep]


def leg_actions(legs: Sequence[Leg], *, height_m: float, flow_lps: float,
                surface: Callable[[float, float], float] | None = None, home_z: float = 0.0) -> list[SprayAction]:
    """Waypoints and sprayer switches for legs flown in order (the first leg's start is where the vehicle
    is): the sprayer goes on at each row's first point and off at its last."""
    out: list[SprayAction] = []
    for leg in legs:
        if surface is not None:
            pts = _profile(leg.points, surface, height_m, home_z)
        else:
            pts = [(x, y, height_m) for x, y in leg.points]
        if leg.spray:
            out.append(("wp", *pts[0]))
            out.append(("spray", flow_lps, 0.0, 0.0))
            out.extend(("wp", *p) for p in pts[1:])
            out.append(("spray", 0.0, 0.0, 0.0))
        else:
            out.extend(("wp", *p) for p in pts[1:])
    # drop consecutive duplicate waypoints
    clean: list[SprayAction] = []
    for a in out:
        if clean and a[0] == "wp" and clean[-1][0] == "wp" and math.dist(a[1:3], clean[-1][1:3]) < 1e-3:
            continue
        clean.append(a)
    return clean
