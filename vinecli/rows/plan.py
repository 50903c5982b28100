"""Spray plans over rows as an operator flies them (ENU m, s, L): :func:`plan_rows`.

* rows are first clipped to the geofence shrunk by a margin (and to the terrain), with one warning
  line each when rows leave them; what is left of each row is its *planned stretch* (``stretches``:
  start and end along the row, m), the part the sections must dose;
* passes: with the sprayer's pattern (``pattern``, :mod:`vinecli.spray.swath`) the passes are
  laid out by :func:`~vinecli.rows.lanes.layout_lanes` (evenly spaced within the effective swath, the
  edge rows dosed like the inner ones; or one pass per row when the rows are a swath or more apart)
  and the plan's ``flow_width_m`` is the track width of the flow (rate x width x speed); without a
  pattern every row is one pass;
* the first pass is the one nearest to the take-off point, entered at its nearer end; the sweep goes
  towards the nearer edge of the block first, then jumps over to finish the other side;
* boustrophedon: each next pass is entered at the end nearest to where the last one ended;
* headland turns sized from the vehicle's speed ``v`` and acceleration ``a``: a semicircle when its
  radius w/2 (w: distance between the two pass ends) allows v^2 / r <= a and it fits inside the fence,
  otherwise a stop turn: run out v^2 / (2 a) past the pass end, cross, run in the same distance. A
  run-out the fence (less its margin) does not leave room for is shortened, down to none: the vehicle
  then brakes inside the pass end, where the speed-scaled flow keeps the dose (a warning says so); the
  passes are never shortened for the turns;
* spray on only over the passes (legs flagged ``spray``: section control closes the sections in turns,
  headlands, transits, outside the fence and a footprint's clearance before a no-spray zone:
  :mod:`vinecli.rows.no_spray`);
* plan length and estimated time (trapezoidal speed profiles with ``a``; take-off and landing at the
  climb / descent speeds); sorties split by tank volume (:func:`split_sorties`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from vinecli.geometry import polyline_length
from vinecli.rows.detect import Polyline
from vinecli.rows.lanes import LaneLayout
from vinecli.rows.no_spray import blocked_area, clearance_m, dosed_stretch, taper_m
from vinecli.rows.passes import Pass, clip_rows, lay_passes, room_ahead

__all__ = ["PATH_ACCEL_MPS2", "Leg", "RowPlan", "plan_accel", "plan_rows", "split_sorties"]

Point = tuple[float, float]

#: acceleration of the built-in autopilot's spray path follower, m/s²
PATH_ACCEL_MPS2 = 1.5


def plan_accel(vehicle: object) -> float:
    """Acceleration the plans assume (m/s²): the spray path follower's, within the vehicle's MPC limit."""
    return min(PATH_ACCEL_MPS2, float(vehicle.control.max_acc_xy))  # type: ignore[attr-defined]


@dataclass
class Leg:
    """One piece of the path: a pass (``spray`` True, ``lane`` its index across the block, ``row`` the row it
    flies over if any) or a transit / turn (spray off)."""

    points: Polyline
    spray: bool
    row: int | None = None
    kind: str = "row"  # "row" | "transit" | "turn-arc" | "turn-stop" | "gap" (across a cut in a row, spray off)
    lane: int | None = None

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
    #: planned stretch of each row (index into the rows given): (start, end) along the row, m
    stretches: dict[int, tuple[float, float]] = field(default_factory=dict)
    #: stretches inside a row's planned stretch not judged: the taper beside a no-spray zone (rows.no_spray)
    holes: dict[int, list[tuple[float, float]]] = field(default_factory=dict)
    #: how the passes were laid out (None: one pass per row, no pattern given)
    layout: LaneLayout | None = None

    @property
    def order(self) -> list[int]:
        """Pass indices (lanes across the block; the row indices when every row is a pass) in spraying order."""
        lanes = [leg.lane for leg in self.legs if leg.spray and leg.lane is not None]
        return [k for j, k in enumerate(lanes) if j == 0 or k != lanes[j - 1]]  # a pass cut by a zone: once

    @property
    def flow_width_m(self) -> float:
        """Track width of the flow (flow = rate x width x speed / 10 000), m; NaN without a pattern."""
        return self.layout.flow_width_m if self.layout is not None else math.nan

    @property
    def length_m(self) -> float:
        """Horizontal path length from the take-off point to the end of the last row, m."""
        return sum(leg.length_m for leg in self.legs)

    @property
    def spray_length_m(self) -> float:
        """Length flown with the sprayer on, m."""
        return sum(leg.length_m for leg in self.legs if leg.spray)

    def path(self, flow: float) -> tuple[Polyline, list[float], list[int]]:
        """The plan as one polyline, ``flow`` on each of its segments over a pass (0 elsewhere), and the points to
        come to rest at (where a transit turns onto the run-in of a pass)."""
        pts: Polyline = [self.legs[0].points[0]] if self.legs else []
        flows: list[float] = []
        stops: list[int] = []
        for leg in self.legs:
            for p in leg.points[1:]:
                pts.append(p)
                flows.append(flow if leg.spray else 0.0)
            if leg.kind == "transit" and len(leg.points) >= 3:
                stops.append(len(pts) - 2)
        return pts, flows, stops

    def summary(self) -> str:
        """One line: rows, first row, turns, length and time."""
        turns = [leg.kind for leg in self.legs if leg.kind.startswith("turn")]
        kinds = ", ".join(f"{turns.count(k)} {k[5:]}" for k in ("turn-arc", "turn-stop") if turns.count(k))
        first = self.order[0] if self.order else None
        lay = self.layout
        what = (f"{len(self.order)} rows from row {first}" if lay is None or lay.mode != "broadcast" else
                f"{len(self.order)} passes {lay.spacing_m:.2f} m apart over {len(self.stretches)} rows from pass {first}")
        return (f"plan: {what}, {len(turns)} headland turns ({kinds or 'none'}), "
                f"{self.length_m:.1f} m ({self.spray_length_m:.1f} m spraying), about {self.time_s:.0f} s")


# ---------------------------------------------------------------- geometry helpers
def row_direction(rows: Sequence[Polyline]) -> tuple[float, float]:
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


def _back_inside(p: Point, d: tuple[float, float], inner: object | None, most: float = 5.0) -> Point:
    """``p`` moved back along ``-d`` (0.05 m steps, at most ``most`` m) until it lies inside ``inner``."""
    if inner is None:
        return p
    from shapely.geometry import Point as P

    k = 0
    q = p
    while not inner.contains(P(q)) and k * 0.05 < most:  # type: ignore[attr-defined]
        k += 1
        q = (p[0] - d[0] * 0.05 * k, p[1] - d[1] * 0.05 * k)
    return q


def _trapezoid_time(d: float, v: float, a: float) -> float:
    """Time to cover ``d`` m from rest to rest with speed limit ``v`` and acceleration ``a``, s."""
    if d <= 0:
        return 0.0
    if d >= v * v / a:
        return d / v + v / a
    return 2.0 * math.sqrt(d / a)


def _turn(p: Point, q: Point, d: tuple[float, float], v: float, a: float, inner: object | None = None
          ) -> tuple[Leg, float]:
    """Headland turn from the end ``p`` of a pass flown along ``d`` to the start ``q`` of the next one, inside
    ``inner`` (a shapely polygon) when given; and how much of the full run-out v²/(2a) was left out (m)."""
    along_p = p[0] * d[0] + p[1] * d[1]
    along_q = q[0] * d[0] + q[1] * d[1]
    h = max(along_p, along_q)
    p1 = (p[0] + d[0] * (h - along_p), p[1] + d[1] * (h - along_p))
    q1 = (q[0] + d[0] * (h - along_q), q[1] + d[1] * (h - along_q))
    w = math.dist(p1, q1)
    r = w / 2
    if r > 0 and v * v / r <= a and room_ahead(((p1[0] + q1[0]) / 2, (p1[1] + q1[1]) / 2), d, inner, r) >= r - 0.05:
        cx, cy = (p1[0] + q1[0]) / 2, (p1[1] + q1[1]) / 2  # a semicircle at cruise speed
        a0 = math.atan2(p1[1] - cy, p1[0] - cx)
        # bulge outwards (along d): pick the rotation sense whose midpoint lies ahead
        mid_ccw = (cx + r * math.cos(a0 + math.pi / 2), cy + r * math.sin(a0 + math.pi / 2))
        sense = 1.0 if (mid_ccw[0] - cx) * d[0] + (mid_ccw[1] - cy) * d[1] > 0 else -1.0
        n = max(6, int(math.ceil(math.pi * r / 0.5)))
        arc = [(cx + r * math.cos(a0 + sense * math.pi * k / n), cy + r * math.sin(a0 + sense * math.pi * k / n))
               for k in range(n + 1)]
        pts = [p, *arc, q]
        kind, short = "turn-arc", 0.0
    else:  # stop turn: run out past the pass end (brake), cross, run in to be at speed at the next pass
        full = v * v / (2 * a)
        p1, q1 = _back_inside(p1, d, inner), _back_inside(q1, d, inner)  # pass ends squared up inside the fence
        e = min(room_ahead(p1, d, inner, full), room_ahead(q1, d, inner, full))
        e = 0.0 if e < 0.05 else e
        pts = [p, (p1[0] + d[0] * e, p1[1] + d[1] * e), (q1[0] + d[0] * e, q1[1] + d[1] * e), q]
        kind, short = "turn-stop", full - e
    clean = [pts[0]]
    for pt in pts[1:]:
        if math.dist(pt, clean[-1]) > 1e-6:
            clean.append(pt)
    return Leg(clean, False, None, kind), short


def _transit(pos: Point, seq: Polyline, v: float, a: float, inner: object | None) -> Leg:
    """Transit from ``pos`` to the start of the pass ``seq``, ending with a straight run-in of v²/(2a) along it (within
    ``inner``): the vehicle is at spraying speed where the pass starts."""
    dx, dy = seq[1][0] - seq[0][0], seq[1][1] - seq[0][1]
    n = math.hypot(dx, dy) or 1.0
    back = (-dx / n, -dy / n)
    e = room_ahead(seq[0], back, inner, v * v / (2 * a))
    pts = [pos, (seq[0][0] + back[0] * e, seq[0][1] + back[1] * e), seq[0]] if e > 0.05 else [pos, seq[0]]
    return Leg([p for i, p in enumerate(pts) if i == 0 or math.dist(p, pts[i - 1]) > 1e-6], False, None, "transit")


def _leg_time(leg: Leg, v: float, a: float) -> float:
    """Estimated time of a leg, s: rows at cruise speed, arcs at cruise speed, stop turns and transits
    as rest-to-rest trapezoids per straight segment (the run-out / run-in brake and accelerate)."""
    if leg.spray or leg.kind == "turn-arc":
        return leg.length_m / v
    segs = [math.dist(p, q) for p, q in zip(leg.points[:-1], leg.points[1:], strict=True)]
    if leg.kind == "turn-stop" and len(segs) == 3:
        return 2 * v / a + _trapezoid_time(segs[1], v, a)
    if leg.kind == "transit" and len(segs) >= 2:  # the last segment is the run-in: accelerate from rest
        return sum(_trapezoid_time(s, v, a) for s in segs[:-1]) + math.sqrt(2.0 * segs[-1] / a)
    return sum(_trapezoid_time(s, v, a) for s in segs)


# ---------------------------------------------------------------- the plan
# parameters: keyword-only options, each with its default (the plan's speed, acceleration, fence, terrain, climb, lanes, no-spray zones); a caller names the ones it sets
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
    pattern: object | None = None,
    band_m: float = 0.6,
    end_margin_m: float = 0.0,
    no_spray: Sequence[Sequence[tuple[float, float]]] = (),
) -> RowPlan:
    """Operator-style plan over ``rows`` (ENU polylines, indices kept) from ``start_xy``; see the module
    docstring. ``climb`` = (altitude m, climb speed m/s, descent speed m/s) adds take-off and landing
    time to the estimate; ``pattern`` (a :class:`~vinecli.spray.swath.SwathPattern`) lays the passes out
    for an even dose on every row's ``band_m`` wide canopy band and runs them on past the row ends by its
    footprint + ``end_margin_m`` (the sprayer's ramp up and down), within the fence. ``no_spray``: the world's
    no-spray zones (rings, grown by their buffer): the passes close their sections the footprint's clearance before
    them and a row's planned stretch ends where the full dose can reach it (:mod:`vinecli.rows.no_spray`)."""
    from shapely.geometry import LineString, Point, Polygon, box

    v, a = float(speed_mps), float(accel_mps2)
    warnings: list[str] = []
    src = [[(float(x), float(y)) for x, y in r] for r in rows]
    idx = [i for i, r in enumerate(src) if len(r) >= 2]
    work = [src[i] for i in idx]
    if not work:
        return RowPlan([], v, a, ["no rows to plan"])
    inner = None  # where the path may go: the fence less its margin, on the terrain
    if terrain_bounds is not None:
        xmin, ymin, xmax, ymax = terrain_bounds
        inner = box(xmin, ymin, xmax, ymax)
        work = clip_rows(work, inner, "terrain", warnings)
    if fence_enu is not None and len(fence_enu) >= 3:
        fenced = Polygon(fence_enu).buffer(-fence_margin_m)
        work = clip_rows(work, fenced, f"{fence_name} (margin {fence_margin_m:g} m)", warnings)
        inner = fenced if inner is None else inner.intersection(fenced)
    keep = [(i, r) for i, r in zip(idx, work, strict=True) if len(r) >= 2 and LineString(r).length > 0.05]
    if not keep:
        return RowPlan([], v, a, [*warnings, "no rows left inside the fence"])
    ux, uy = row_direction([r for _, r in keep])
    blocked = blocked_area(no_spray, clearance_m(pattern, end_margin_m))
    passes, layout = lay_passes(keep, (ux, uy), pattern, band_m, inner, warnings, end_margin_m, blocked)
    if not passes:
        return RowPlan([], v, a, [*warnings, "no passes left outside the no-spray zones"])
    # the pieces of one lane (a row cut into stretches) fly as one pass, the gaps with the sprayer off
    groups: list[list[Pass]] = []
    for p in passes:
        if groups and (layout is None or layout.mode != "listed") and p[0] == groups[-1][0][0]:
            groups[-1].append(p)
        else:
            groups.append([p])
    # order across the passes; the first is the nearest to the start (rows listed twice: in the order listed)
    start = Point(start_xy)
    across = sorted(groups, key=lambda g: -uy * (g[0][2][0][0] + g[0][2][-1][0]) + ux * (g[0][2][0][1] + g[0][2][-1][1]))
    k0 = min(range(len(across)), key=lambda k: (min(LineString(q[2]).distance(start) for q in across[k]), k))
    left, right = across[:k0][::-1], across[k0 + 1:]
    first, second = (left, right) if len(left) <= len(right) else (right, left)
    sequence = [across[k0], *first, *second]
    if layout is not None and layout.mode == "listed":
        sequence, first, second = groups, [], []

    legs: list[Leg] = []
    pos = (float(start_xy[0]), float(start_xy[1]))
    short: list[float] = []
    for n, group in enumerate(sequence):
        for i, (lane, row, r) in enumerate(_from_nearer_end(group, pos, (ux, uy))):
            seq = r if math.dist(r[0], pos) <= math.dist(r[-1], pos) else r[::-1]
            if i > 0:  # the next stretch of the same pass, straight ahead across the gap
                legs.append(Leg([pos, seq[0]], False, None, "gap", lane))
            elif n == 0 or (first and n == len(first) + 1 and second):  # fly to the first pass / jump over
                legs.append(_transit(pos, seq, v, a, inner))
            else:
                dx, dy = legs[-1].points[-1][0] - legs[-1].points[-2][0], legs[-1].points[-1][1] - legs[-1].points[-2][1]
                dn = math.hypot(dx, dy) or 1.0
                turn, left_out = _turn(pos, seq[0], (dx / dn, dy / dn), v, a, inner)
                legs.append(turn)
                if left_out > 0.05:
                    short.append(left_out)
            legs.append(Leg(seq, True, row, "row", lane))
            pos = seq[-1]
    if short:
        where = fence_name if fence_enu is not None and len(fence_enu) >= 3 else "terrain"
        warnings.append(f"{len(short)} headland turns shortened to fit the {where}: the vehicle brakes inside "
                        f"the pass end (up to {max(short):.1f} m of run-out left out; the speed-scaled flow keeps the dose)")
    stretches, holes = _judged(src, keep, no_spray, taper_m(pattern, end_margin_m), warnings)
    plan = RowPlan(legs, v, a, warnings, stretches=stretches, holes=holes, layout=layout)
    t = sum(_leg_time(leg, v, a) for leg in legs)
    if climb is not None:
        alt, up, down = climb
        t += alt / up + alt / down
    plan.time_s = round(t, 1)
    return plan


def _judged(src: list[Polyline], keep: list[tuple[int, Polyline]], no_spray: Sequence[Sequence[tuple[float, float]]],
            taper: float, warnings: list[str]
            ) -> tuple[dict[int, tuple[float, float]], dict[int, list[tuple[float, float]]]]:
    """The planned stretch of each kept row (along its source polyline, m) and its unjudged holes: the row clipped
    to the fence, less the ``taper`` beside the no-spray zones (:func:`~vinecli.rows.no_spray.dosed_stretch`)."""
    clear = blocked_area(no_spray, taper)
    dosed = {i: dosed_stretch(src[i], r, clear) for i, r in keep}
    lost = [i for i, (st, _) in dosed.items() if st is None]
    if lost:
        warnings.append(f"rows {lost} lie within {taper:.1f} m of a no-spray zone: no stretch of them can get the "
                        "full dose without spraying into the zone (not judged)")
    return ({i: st for i, (st, _) in dosed.items() if st is not None},
            {i: h for i, (st, h) in dosed.items() if st is not None and h})


def _from_nearer_end(group: list[Pass], pos: Point, u: tuple[float, float]) -> list[Pass]:
    """The stretches of one pass in flight order: along the rows from the end nearer to ``pos``."""
    if len(group) == 1:
        return group
    pieces = sorted(group, key=lambda q: u[0] * (q[2][0][0] + q[2][-1][0]) + u[1] * (q[2][0][1] + q[2][-1][1]))
    lo = min(math.dist(pos, pieces[0][2][0]), math.dist(pos, pieces[0][2][-1]))
    hi = min(math.dist(pos, pieces[-1][2][0]), math.dist(pos, pieces[-1][2][-1]))
    return pieces if lo <= hi else pieces[::-1]


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
            sorties[-1].append(Leg([(float(x), float(y)) for x, y in piece.coords], True, leg.row, "row", leg.lane))
            left -= (end - done) * per_m
            done = end
    # a sortie is its rows and the turns between them (the flights from and to home are the export's)
    for s in sorties:
        while s and not s[-1].spray:
            s.pop()
        while s and not s[0].spray:
            s.pop(0)
    return [s for s in sorties if s]
