"""Spray legs -> mission waypoints: terrain-following waypoints, sprayer on over the rows only.

Heights: waypoints are MAV_FRAME_GLOBAL_RELATIVE_ALT (above home). With a ``surface`` (ENU z of the DSM
surface, i.e. the canopy tops), each leg is sampled every 0.5 m, the surface is lifted to its running
maximum over +-1 m (the spray height is kept above the canopy, not into its gaps) and the profile
``surface + height - home surface`` is simplified to 0.2 m (Douglas-Peucker in (distance, altitude)):
extra waypoints where the terrain bends, none on flat ground.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from vinecli.rows.plan import Leg

__all__ = ["SprayAction", "leg_actions"]

#: ("wp", x, y, alt above home m) or ("spray", flow L/s, 0, 0)
SprayAction = tuple[str, float, float, float]

_SAMPLE_M, _LIFT_M, _TOL_M = 0.5, 1.0, 0.2


def _profile(points: Sequence[tuple[float, float]], surface: Callable[[float, float], float], height: float,
             home_z: float) -> list[tuple[float, float, float]]:
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
    z = maximum_filter1d(z, max(1, int(round(2 * _LIFT_M / (ds[1] - ds[0])))) + 1)
    alt = z + height - home_z
    # keep the polyline's own vertices, plus the profile's bends
    keep = {0, n - 1}
    simp = LineString(np.column_stack([ds, alt])).simplify(_TOL_M, preserve_topology=False)
    keep |= {int(np.argmin(np.abs(ds - d))) for d, _ in simp.coords}
    cum = np.concatenate([[0.0], np.cumsum([math.dist(a, b) for a, b in zip(points[:-1], points[1:], strict=True)])])
    keep |= {int(np.argmin(np.abs(ds - c))) for c in cum}
    return [(float(xy[i, 0]), float(xy[i, 1]), round(float(alt[i]), 3)) for i in sorted(keep)]


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
