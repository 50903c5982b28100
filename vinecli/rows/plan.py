"""Spray plans over rows as an operator flies them (ENU m, s, L): :func:`plan_rows`.

* rows are first clipped to the geofence shrunk by a margin plus the headland the turns need (and to
  the terrain), with one warning line each when rows leave them;
* the first row is the one nearest to the take-off point, entered at its nearer end; the sweep goes
  towards the nearer edge of the block first, then jumps over to finish the other side;
* boustrophedon: each next row is entered at the end nearest to where the last one ended;
* headland turns sized from the vehicle's speed ``v`` and acceleration ``a``: a semicircle when its
  radius w/2 (w: distance between the two row ends) allows v^2 / r <= a, otherwise a stop turn: run
  out v^2 / (2 a) past the row end (the vehicle brakes after the last sprayed metre), cross, run in
  the same distance (it is at speed when spraying starts);
* spray on only over the rows (legs flagged ``spray``);
* plan length and estimated time (trapezoidal speed profiles with ``a``; take-off and landing at the
  climb / descent speeds); sorties split by tank volume (:func:`split_sorties`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from vinecli.rows.detect import Polyline
from vinecli.rows.geometry import polyline_length

__all__ = ["PATH_ACCEL_MPS2", "Leg", "RowPlan", "plan_accel", "plan_rows", "split_sorties"]

Point = tuple[float, float]

#: acceleration of the built-in autopilot's spray path follower, m/s²
PATH_ACCEL_MPS2 = 1.5


def plan_accel(vehicle: object) -> float:
    """Acceleration the plans assume (m/s²): the spray path follower's, within the vehicle's MPC limit."""
    return min(PATH_ACCEL_MPS2, float(vehicle.control.max_acc_xy))  # type: ignore[attr-defined]


@dataclass
class Leg:
    """One piece of the path: a row (``spray`` True, ``row`` its index) or a transit / turn (spray off)."""

    points: Polyline
    spray: bool
    row: int | None = None
    kind: str = "row"  # "row" | "transit" | "turn-arc" | "turn-stop"

    @property
    def length_m(self) -> float:
        """Length of the leg, m."""
        return polyline_length(self.points)


@dataclass
class RowPlan:
    """Legs in flight order from the take-off point, with length (m) and time (s) estimates."""

    legs: list[Leg]
    speed_mps: float
    accel_mps2: float
    warnings: list[str] = field(default_factory=list)
    time_s: float = 0.0

    @property
    def order(self) -> list[int]:
        """Row indices in the order they are sprayed."""
        return [leg.row for leg in self.legs if leg.spray and leg.row is not None]

    @property
    def length_m(self) -> float:
        """Horizontal path length from the take-off point to the end of the last row, m."""
        return sum(leg.length_m for leg in self.legs)

    @property
    def spray_length_m(self) -> float:
        """Length flown with the sprayer on, m."""
        return sum(leg.length_m for leg in self.legs if leg.spray)

    def path(self, flow_lps: float) -> tuple[Polyline, list[float]]:
        """The plan as one polyline and the flow (L/s) of each of its segments (0 off the rows)."""
        pts: Polyline = [self.legs[0].points[0]] if self.legs else []
        flows: list[float] = []
        for leg in self.legs:
            for p in leg.points[1:]:
                pts.append(p)
                flows.append(flow_lps if leg.spray else 0.0)
        return pts, flows

    def summary(self) -> str:
        """One line: rows, first row, turns, length and time."""
        turns = [leg.kind for leg in self.legs if leg.kind.startswith("turn")]
        kinds = ", ".join(f"{turns.count(k)} {k[5:]}" for k in ("turn-arc", "turn-stop") if turns.count(k))
        first = self.order[0] if self.order else None
        return (f"plan: {len(self.order)} rows from row {first}, {len(turns)} headland turns ({kinds or 'none'}), "
                f"{self.length_m:.1f} m ({self.spray_length_m:.1f} m spraying), about {self.time_s:.0f} s")


# ---------------------------------------------------------------- geometry helpers
def _direction(rows: Sequence[Polyline]) -> tuple[float, float]:
    """Unit vector of the mean row direction (end-to-end vectors, sign-aligned)."""
    sx = sy = 0.0
    ref: Point | None = None
    for r in rows:
        dx, dy = r[-1][0] - r[0][0], r[-1][1] - r[0][1]
        if ref is None:
            ref = (dx, dy)
        elif dx * ref[0] + dy * ref[1] < 0:
            dx, dy = -dx, -dy
        sx, sy = sx + dx, sy + dy
    n = math.hypot(sx, sy)
    if n == 0:
        raise ValueError("rows have no length")
    return sx / n, sy / n


def _clip(rows: list[Polyline], region: object, what: str, warnings: list[str]) -> list[Polyline]:
    """Rows clipped to a shapely polygon (longest piece kept, [] when none: the list stays aligned with the
    input); one warning line when any row leaves it."""
    from shapely.geometry import LineString

    out: list[Polyline] = []
    cut = 0.0
    n_out = 0
    for r in rows:
        if len(r) < 2:
            out.append([])
            continue
        line = LineString(r)
        piece = line.intersection(region)  # type: ignore[arg-type]
        parts = [g for g in getattr(piece, "geoms", [piece]) if g.geom_type == "LineString" and not g.is_empty]
        if not parts:  # wholly outside: kept as an empty row so the indices stay aligned
            n_out += 1
            cut = max(cut, line.length)
            out.append([])
            continue
        best = max(parts, key=lambda g: g.length)
        if line.length - best.length > 0.05:
            n_out += 1
            cut = max(cut, line.length - best.length)
        pts = [(float(x), float(y)) for x, y in best.coords]
        # keep the row's own direction
        if math.dist(pts[0], r[0]) > math.dist(pts[-1], r[0]):
            pts = pts[::-1]
        out.append(pts)
    if n_out:
        warnings.append(f"{n_out} of {len(rows)} rows leave the {what}: clipped (up to {cut:.1f} m cut from a row)")
    return out


def _headland_fits(line: object, inner: object, d: float, inward: float, head: float) -> bool:
    """Whether the point ``head`` m straight on past distance ``d`` along ``line`` (leaving it outwards;
    ``inward`` = +1 at the start, -1 at the end) lies inside ``inner``."""
    from shapely.geometry import Point

    p = line.interpolate(d)  # type: ignore[attr-defined]
    q = line.interpolate(min(line.length, max(0.0, d + inward * 0.05)))  # type: ignore[attr-defined]
    dx, dy = p.x - q.x, p.y - q.y
    n = math.hypot(dx, dy) or 1.0
    return bool(inner.contains(Point(p.x + dx / n * head, p.y + dy / n * head)))  # type: ignore[attr-defined]


def _fit_headlands(rows: list[Polyline], inner: object, head: float, what: str, warnings: list[str]
                   ) -> list[Polyline]:
    """Shorten row ends (0.1 m steps) whose headland, ``head`` m straight on past the end, would leave ``inner``."""
    from shapely.geometry import LineString
    from shapely.ops import substring

    out: list[Polyline] = []
    cut = 0.0
    for r in rows:
        if len(r) < 2:
            out.append([])
            continue
        line = LineString(r)
        a, b = 0.0, line.length
        while a < b and not _headland_fits(line, inner, a, 1.0, head):
            a += 0.1
        while b > a and not _headland_fits(line, inner, b, -1.0, head):
            b -= 0.1
        if b - a < 0.1:
            cut = max(cut, line.length)
            out.append([])
            continue
        cut = max(cut, a + (line.length - b))
        out.append([(float(x), float(y)) for x, y in substring(line, a, b).coords])
    if cut > 0.05:
        warnings.append(f"rows end too close to the {what} for a {head:.1f} m headland: shortened (up to "
                        f"{cut:.1f} m per row)")
    return out


def _trapezoid_time(d: float, v: float, a: float) -> float:
    """Time to cover ``d`` m from rest to rest with speed limit ``v`` and acceleration ``a``, s."""
    if d <= 0:
        return 0.0
    if d >= v * v / a:
        return d / v + v / a
    return 2.0 * math.sqrt(d / a)


def _turn(p: Point, q: Point, d: tuple[float, float], v: float, a: float) -> Leg:
    """Headland turn from the end ``p`` of a row flown along ``d`` to the start ``q`` of the next row."""
    along_p = p[0] * d[0] + p[1] * d[1]
    along_q = q[0] * d[0] + q[1] * d[1]
    h = max(along_p, along_q)
    p1 = (p[0] + d[0] * (h - along_p), p[1] + d[1] * (h - along_p))
    q1 = (q[0] + d[0] * (h - along_q), q[1] + d[1] * (h - along_q))
    w = math.dist(p1, q1)
    r = w / 2
    if r > 0 and v * v / r <= a:  # a semicircle at cruise speed
        cx, cy = (p1[0] + q1[0]) / 2, (p1[1] + q1[1]) / 2
        a0 = math.atan2(p1[1] - cy, p1[0] - cx)
        # bulge outwards (along d): pick the rotation sense whose midpoint lies ahead
        mid_ccw = (cx + r * math.cos(a0 + math.pi / 2), cy + r * math.sin(a0 + math.pi / 2))
        sense = 1.0 if (mid_ccw[0] - cx) * d[0] + (mid_ccw[1] - cy) * d[1] > 0 else -1.0
        n = max(6, int(math.ceil(math.pi * r / 0.5)))
        arc = [(cx + r * math.cos(a0 + sense * math.pi * k / n), cy + r * math.sin(a0 + sense * math.pi * k / n))
               for k in range(n + 1)]
        pts = [p, *arc, q]
        kind = "turn-arc"
    else:  # stop turn: brake past the row end, cross, run in to be at speed at the next row
        e = v * v / (2 * a)
        pts = [p, (p1[0] + d[0] * e, p1[1] + d[1] * e), (q1[0] + d[0] * e, q1[1] + d[1] * e), q]
        kind = "turn-stop"
    clean = [pts[0]]
    for pt in pts[1:]:
        if math.dist(pt, clean[-1]) > 1e-6:
            clean.append(pt)
    return Leg(clean, False, None, kind)


def _leg_time(leg: Leg, v: float, a: float) -> float:
    """Estimated time of a leg, s: rows at cruise speed, arcs at cruise speed, stop turns and transits
    as rest-to-rest trapezoids per straight segment (the run-out / run-in brake and accelerate)."""
    if leg.spray or leg.kind == "turn-arc":
        return leg.length_m / v
    segs = [math.dist(p, q) for p, q in zip(leg.points[:-1], leg.points[1:], strict=True)]
    if leg.kind == "turn-stop" and len(segs) == 3:
        return 2 * v / a + _trapezoid_time(segs[1], v, a)
    return sum(_trapezoid_time(s, v, a) for s in segs)


# ---------------------------------------------------------------- the plan
def plan_rows(
    rows: Sequence[Sequence[tuple[float, float]]],
    start_xy: tuple[float, float],
    *,
    speed_mps: float,
    accel_mps2: float,
    fence_enu: Sequence[tuple[float, float]] | None = None,
    fence_margin_m: float = 1.0,
    fence_name: str = "geofence",
    terrain_bounds: tuple[float, float, float, float] | None = None,
    climb: tuple[float, float, float] | None = None,
) -> RowPlan:
    """Operator-style plan over ``rows`` (ENU polylines, indices kept) from ``start_xy``; see the module
    docstring. ``climb`` = (altitude m, climb speed m/s, descent speed m/s) adds take-off and landing
    time to the estimate."""
    from shapely.geometry import LineString, Point, Polygon, box

    v, a = float(speed_mps), float(accel_mps2)
    warnings: list[str] = []
    src = [[(float(x), float(y)) for x, y in r] for r in rows]
    idx = [i for i, r in enumerate(src) if len(r) >= 2]
    work = [src[i] for i in idx]
    if not work:
        return RowPlan([], v, a, ["no rows to plan"])
    head = v * v / (2 * a)  # run-out past a row end (stop turn); an arc needs at most its radius
    if terrain_bounds is not None:
        xmin, ymin, xmax, ymax = terrain_bounds
        work = _clip(work, box(xmin, ymin, xmax, ymax), "terrain", warnings)
    if fence_enu is not None and len(fence_enu) >= 3:
        inner = Polygon(fence_enu).buffer(-fence_margin_m)
        work = _clip(work, inner, f"{fence_name} (margin {fence_margin_m:g} m)", warnings)
        work = _fit_headlands(work, inner, head, fence_name, warnings)
    keep = [(i, r) for i, r in zip(idx, work, strict=True) if len(r) >= 2 and LineString(r).length > 0.05]
    if not keep:
        return RowPlan([], v, a, [*warnings, "no rows left inside the fence"])
    ux, uy = _direction([r for _, r in keep])
    # order across the rows; the first row is the nearest to the start
    start = Point(start_xy)
    across = sorted(keep, key=lambda ir: -uy * (ir[1][0][0] + ir[1][-1][0]) + ux * (ir[1][0][1] + ir[1][-1][1]))
    k0 = min(range(len(across)), key=lambda k: (LineString(across[k][1]).distance(start), k))
    left, right = across[:k0][::-1], across[k0 + 1:]
    first, second = (left, right) if len(left) <= len(right) else (right, left)
    sequence = [across[k0], *first, *second]

    legs: list[Leg] = []
    pos = (float(start_xy[0]), float(start_xy[1]))
    for n, (i, r) in enumerate(sequence):
        seq = r if math.dist(r[0], pos) <= math.dist(r[-1], pos) else r[::-1]
        if n == 0 or (first and n == len(first) + 1 and second):  # fly to the first row / jump over
            legs.append(Leg([pos, seq[0]], False, None, "transit"))
        else:
            dx, dy = legs[-1].points[-1][0] - legs[-1].points[-2][0], legs[-1].points[-1][1] - legs[-1].points[-2][1]
            dn = math.hypot(dx, dy) or 1.0
            legs.append(_turn(pos, seq[0], (dx / dn, dy / dn), v, a))
        legs.append(Leg(seq, True, i, "row"))
        pos = seq[-1]
    plan = RowPlan(legs, v, a, warnings)
    t = sum(_leg_time(leg, v, a) for leg in legs)
    if climb is not None:
        alt, up, down = climb
        t += alt / up + alt / down
    plan.time_s = round(t, 1)
    return plan


def split_sorties(plan: RowPlan, flow_lps: float, tank_l: float) -> list[list[Leg]]:
    """The plan's legs cut into sorties of at most ``tank_l`` litres sprayed each (rows at ``flow_lps``
    and the plan's speed); a row that does not fit is cut where the tank runs out and resumed there."""
    from shapely.geometry import LineString
    from shapely.ops import substring

    if tank_l <= 0 or flow_lps <= 0:
        return [plan.legs]
    per_m = flow_lps / plan.speed_mps  # L per metre of row
    sorties: list[list[Leg]] = [[]]
    left = tank_l
    for leg in plan.legs:
        if not leg.spray:
            sorties[-1].append(leg)
            continue
        line = LineString(leg.points)
        done = 0.0
        while line.length - done > 1e-6:
            can = left / per_m
            if can <= 1e-6:
                sorties.append([])
                left = tank_l
                continue
            end = min(line.length, done + can)
            piece = substring(line, done, end)
            sorties[-1].append(Leg([(float(x), float(y)) for x, y in piece.coords], True, leg.row, "row"))
            left -= (end - done) * per_m
            done = end
    # a sortie is its rows and the turns between them (the flights from and to home are the export's)
    for s in sorties:
        while s and not s[-1].spray:
            s.pop()
        while s and not s[0].spray:
            s.pop(0)
    return [s for s in sorties if s]
