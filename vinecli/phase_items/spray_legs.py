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

A pass's row ends are no waypoints: on its straight run-on they would make a short leg that holds a firmware's
jerk-limited speed (measured: ArduCopter at 0.89 m/s over a 1.85 m run-on leg after the run-in stop, below
AC_Sprayer's 1 m/s minimum, so its sprayer came on 1.5 m into the row; at the far end both firmwares braked inside
the row). A transit's run-in point carries the pass's heading (param4): the vehicle turns to face along the pass
before it accelerates into it (measured: PX4 v1.15 yawing 180 deg while accelerating out of the run-in left it
0.3 m beside the row over the first 3 m, the first metre dosed 0.54x).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from vinecli.geometry import distance_along
from vinecli.rows.plan import Leg

__all__ = ["SprayAction", "leg_actions"]

#: ("wp", x, y, alt above home m), ("spray", flow L/s, 0, 0) or ("face", yaw ENU rad, 0, 0): the last waypoint's yaw
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
    return _profile_at(points, surface, height, home_z, min_leg)[1]


def _profile_at(points: Sequence[tuple[float, float]], surface: Callable[[float, float], float], height: float,
                home_z: float, min_leg: float = MIN_LEG_M, breaks: Sequence[float] = ()
                ) -> tuple[list[float], list[tuple[float, float, float]]]:
    """:func:`_profile` with the waypoints' distances along the polyline (m); ``breaks``: distances along it that
    must be waypoints too (flow changes), the legs between them split like the polyline's own pieces, so that no
    waypoint falls just before or after one."""
    from scipy.ndimage import maximum_filter1d
    from shapely.geometry import LineString

    line = LineString(points)
    if line.length < 1e-6:
        return [0.0], [(float(x), float(y), round(surface(x, y) + height - home_z, 3)) for x, y in points[:1]]
    n = max(2, int(math.ceil(line.length / _SAMPLE_M)) + 1)
    step = line.length / (n - 1)
    cum = np.concatenate([[0.0], np.cumsum([math.dist(a, b) for a, b in zip(points[:-1], points[1:], strict=True)])])
    inner = np.array([float(b) for b in breaks if 0.0 < b < line.length])
    ds = np.unique(np.concatenate([np.linspace(0.0, line.length, n), inner]))  # a break is a sample of its own
    cum = np.unique(np.concatenate([cum, inner]))
    xy = np.array([(p.x, p.y) for p in (line.interpolate(d) for d in ds)])
    z = np.array([surface(float(x), float(y)) for x, y in xy])
    need = maximum_filter1d(z, max(1, int(round(2 * _LIFT_M / step))) + 1) + height - home_z
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
    return ([float(ds[ki[j]]) for j in keep],
            [(float(xy[ki[j], 0]), float(xy[ki[j], 1]), round(float(alt[j]), 3)) for j in keep])


def _waypoints(points: Sequence[tuple[float, float]], height_m: float,
               surface: Callable[[float, float], float] | None, home_z: float) -> list[tuple[float, float, float]]:
    if surface is not None:
        return _profile(points, surface, height_m, home_z)
    return [(x, y, height_m) for x, y in points]


def _straight(points: Sequence[tuple[float, float]], tol_m: float = 0.01) -> list[tuple[float, float]]:
    """``points`` without the vertices that lie on the straight line of their neighbours (within ``tol_m``)."""
    out = [points[0]]
    for i in range(1, len(points) - 1):
        (ax, ay), (bx, by), (cx, cy) = out[-1], points[i], points[i + 1]
        n = math.hypot(cx - ax, cy - ay)
        if n <= 0.0 or abs((bx - ax) * (cy - ay) - (by - ay) * (cx - ax)) / n > tol_m:
            out.append(points[i])
    return [*out, points[-1]]


def _pass_actions(legs: Sequence[Leg], flows: Sequence[float], height_m: float,
                  surface: Callable[[float, float], float] | None, home_z: float) -> list[SprayAction]:
    """One pass of consecutive spray legs at their own flows: the pass's waypoints as one profile whose knots
    include the points where the flow changes (a terrain-following waypoint a metre from a change made a leg
    of 0.9-2.2 m there: PX4 v1.15 slowed to 0.7-0.9 m/s over it at its fixed flow, 2-2.4x the rate over ~2 m), a
    waypoint there (on the profile's straight line without terrain), the flow switched there."""
    poly = _straight([*legs[0].points, *(p for leg in legs[1:] for p in leg.points[1:])])
    starts, d = [], 0.0
    for leg in legs[:-1]:
        d += sum(math.dist(a, b) for a, b in zip(leg.points[:-1], leg.points[1:], strict=True))
        starts.append(d)
    if surface is not None:
        changes = [s for k, s in enumerate(starts, 1) if flows[k] != flows[k - 1]]
        at, wps = _profile_at(poly, surface, height_m, home_z, breaks=changes)
    else:
        at = [0.0, *np.cumsum([math.dist(a, b) for a, b in zip(poly[:-1], poly[1:], strict=True)]).tolist()]
        wps = [(x, y, height_m) for x, y in poly]
    cum = np.array(at)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(np.asarray(poly), axis=0).T))])
    out: list[SprayAction] = [("wp", *wps[0]), ("spray", flows[0], 0.0, 0.0)]
    events = sorted([(a, 0, k) for k, a in enumerate(at[1:], start=1)] + [(s, 1, k) for k, s in enumerate(starts, 1)])
    on, last = flows[0], 0.0
    for a, kind, k in events:
        if kind == 0:
            out.append(("wp", *wps[k]))
            last = a
        elif flows[k] != on:
            if a - last > 1e-6:  # not at a waypoint already: one on the profile's straight leg there
                x = float(np.interp(a, along, [p[0] for p in poly]))
                y = float(np.interp(a, along, [p[1] for p in poly]))
                out.append(("wp", x, y, round(float(np.interp(a, cum, [w[2] for w in wps])), 3)))
            out.append(("spray", flows[k], 0.0, 0.0))
            on = flows[k]
    out.append(("spray", 0.0, 0.0, 0.0))
    return out


# parameters: the legs, then keyword-only options with defaults (heights, flows, terrain, the sprayer's kind)
def leg_actions(legs: Sequence[Leg], *, height_m: float, flow_lps: float,
                surface: Callable[[float, float], float] | None = None, home_z: float = 0.0,
                leg_flows: Sequence[float] | None = None, open_at_run_in: float = 0.0) -> list[SprayAction]:
    """Waypoints and sprayer switches for legs flown in order (the first leg's start is where the vehicle
    is): the sprayer goes on at each row's first point and off at its last. ``leg_flows``: each spray leg's own
    flow (L/s; segment rates): consecutive spray legs are one pass (:func:`_pass_actions`). ``open_at_run_in`` (m,
    0: never): a sprayer that sprays only above a ground speed (ArduPilot's AC_Sprayer) goes on at the run-in point
    before a pass instead when it lies at most this far behind (:func:`_on_at_run_in`)."""
    out: list[SprayAction] = []
    i = 0
    while i < len(legs):
        leg = legs[i]
        if leg.spray and leg_flows is not None:
            j = i
            while j + 1 < len(legs) and legs[j + 1].spray:
                j += 1
            out += _pass_actions(legs[i:j + 1], leg_flows[i:j + 1], height_m, surface, home_z)
            i = j + 1
            continue
        # a pass's row ends lie on the straight line of its run-on: no waypoint there (a firmware's jerk-limited
        # trajectory would hold the short run-on leg at ~0.9 m/s, below AC_Sprayer's minimum speed)
        pts = _waypoints(_straight(leg.points) if leg.spray else leg.points, height_m, surface, home_z)
        if leg.spray:
            out.append(("wp", *pts[0]))
            out.append(("spray", flow_lps, 0.0, 0.0))
            out.extend(("wp", *p) for p in pts[1:])
            out.append(("spray", 0.0, 0.0, 0.0))
        else:
            out.extend(("wp", *p) for p in pts[1:])
            if leg.kind == "transit" and len(leg.points) >= 3 and len(pts) >= 2:  # face along the pass from the run-in
                (ax, ay), (bx, by) = leg.points[-2], leg.points[-1]  # point on (its waypoint, or the nearest one)
                k = min(range(1, len(pts)), key=lambda j: math.dist(pts[j][:2], (ax, ay)))
                out.insert(len(out) - len(pts) + 1 + k, ("face", math.atan2(by - ay, bx - ax), 0.0, 0.0))
        i += 1
    # drop consecutive duplicate waypoints
    clean: list[SprayAction] = []
    for a in out:
        if clean and a[0] == "wp" and clean[-1][0] == "wp" and math.dist(a[1:3], clean[-1][1:3]) < 1e-3:
            continue
        clean.append(a)
    return _on_at_run_in(clean, open_at_run_in) if open_at_run_in > 0.0 else clean


def _on_at_run_in(acts: list[SprayAction], run_in_m: float, tol_m: float = 0.05) -> list[SprayAction]:
    """``acts`` with each pass's first waypoint dropped and its sprayer switched on at the run-in point before it,
    where that waypoint lies on the straight line from the run-in point (at most ``run_in_m`` behind) to the next
    one. A waypoint a fence-limited run-in (0.85 m) after the run-in point held ArduCopter at 0.45-0.6 m/s, it passed
    1 m/s (SPRAY_SPEED_MIN) 1 m before the row and AC_Sprayer (3 Hz, 100 ms delay) switched on 0.7 s later, at the
    row: its first 2 m at 0.7x (the sample field's 26 L/ha cells -12 %). Switched on at rest, AC_Sprayer sprays from
    its minimum speed (the litres per metre follow the ground speed) as the vehicle accelerates through the pass
    start."""
    out = list(acts)
    i = 0
    while i < len(out):
        if out[i][0] == "spray" and out[i][1] > 0.0 and i >= 1 and out[i - 1][0] == "wp":
            s = out[i - 1]
            j = i - 2
            while j >= 0 and out[j][0] == "face":
                j -= 1
            k = i + 1
            while k < len(out) and out[k][0] != "wp":
                k += 1
            on = j >= 0 and out[j][0] == "wp" and k < len(out) and not any(
                a[0] == "spray" for a in out[i + 1:k])
            if on and math.dist(out[j][1:3], s[1:3]) <= run_in_m and _between(out[j][1:3], s[1:3], out[k][1:3], tol_m):
                del out[i - 1]  # the pass start: the switch moves to the run-in point's end
                continue
        i += 1
    return out


def _between(a: Sequence[float], p: Sequence[float], b: Sequence[float], tol_m: float) -> bool:
    """``p`` lies on the segment from ``a`` to ``b`` (within ``tol_m``), strictly between them."""
    n = math.dist(a, b)
    if n <= tol_m:
        return False
    d, s = distance_along(np.array([p[0]]), np.array([p[1]]), [(a[0], a[1]), (b[0], b[1])])
    return 0.0 < float(s[0]) < n and float(d[0]) <= tol_m
