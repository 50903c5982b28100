"""Setpoint generation along polylines for the built-in autopilot (plain floats).

A :class:`PathFollower` moves a "carrot" along a polyline at a cruise speed with limited
acceleration, slowing down for corners and the end point, and never running more than
``max_lead_m`` ahead of the vehicle. Each segment carries a sprayer flow (L/s), so a
boustrophedon pattern is one path with flow on along rows and off in the turns. Heights
are absolute ENU z, or height above the terrain under the carrot when ``terrain`` is given
(then low-passed with ``terrain_tau_s`` and limited to ``max_vz``: a DSM is rough).

Terrain look-ahead (as a terrain-following sprayer's radar/DSM look-ahead): the low-passed height
would meet a terrain step (a building or tree edge) too late, so the carrot also keeps above a
floor from the path ahead. Over ``lookahead_m`` (default: cruise speed × ``lookahead_s`` + the
braking distance v²/2a) the demanded height z_d(s') = path z + terrain is reduced by the height
the carrot can climb on the way there at ``climb_frac`` × ``max_vz``:
``floor(s) = max_{s ≤ s' ≤ s+L} [z_d(s') - (s' - s) k] - margin``, ``k = climb_frac · max_vz / speed``,
``margin = floor_margin_frac`` × the set height. Ridges and slopes the carrot can follow give no
floor above the low-passed height (no change there); a step makes the carrot climb before it,
rate-limited. The demand is sampled every ``_PROFILE_DS`` m along the path when it is built,
so the per-update cost is one slice max.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from vinecli.frames import Vec3

_PROFILE_DS = 0.2  # m between samples of the terrain demand along the path


class PathFollower:
    """Carrot along ``points`` (x, y, z): ``z`` is ENU m, or height above ``terrain(x, y)``.

    ``flows[i]`` is the sprayer flow on segment i (points[i] -> points[i+1]), ``speeds[i]`` (m/s) a lower cruise
    speed there (None: ``speed`` everywhere; e.g. where a prescribed rate needs more flow than the pump has); ``max_up`` /
    ``max_down`` (m/s) cap the carrot's vertical speed on climbing / descending segments; the carrot comes to
    rest at the points whose indices are in ``stops``. On a segment with flow, above ``spray_accel_above`` (m/s) the
    carrot speeds up at ``spray_accel`` (m/s²) at most: the vehicle's pitch while it accelerates tilts the nozzles.
    """

    # parameters: keyword-only tuning with defaults (speeds, accelerations, lead and look-ahead);
    # a caller names the few it changes
    def __init__(self, points: Sequence[Vec3], speed: float, *, accel: float = 1.5, flows: Sequence[float] | None = None,
                 terrain: Callable[[float, float], float] | None = None, acceptance_m: float = 0.5,
                 max_lead_m: float = 2.5, corner_speed: float = 0.3, terrain_tau_s: float = 0.4,
                 max_vz: float = 1.5, max_up: float = math.inf, max_down: float = math.inf,
                 lookahead_s: float = 2.0, lookahead_m: float | None = None, climb_frac: float = 0.5,
                 floor_margin_frac: float = 0.25, stops: Sequence[int] = (),
                 speeds: Sequence[float] | None = None, spray_accel: float = math.inf,
                 spray_accel_above: float = 0.0) -> None:
        pts: list[Vec3] = [(float(p[0]), float(p[1]), float(p[2])) for p in points]
        # drop zero-length segments
        clean = [pts[0]]
        clean_flows: list[float] = []
        clean_speeds: list[float] = []
        stop_at: list[int] = []
        for i, p in enumerate(pts[1:]):
            q = clean[-1]
            if math.hypot(p[0] - q[0], p[1] - q[1]) + abs(p[2] - q[2]) > 1e-6:
                clean.append(p)
                clean_flows.append(float(flows[i]) if flows is not None else 0.0)
                clean_speeds.append(float(speeds[i]) if speeds is not None else speed)
            if i + 1 in stops:
                stop_at.append(len(clean) - 1)
        self.points = clean
        self.flows = clean_flows if clean_flows else [0.0]
        self.speed = speed
        self.accel = accel
        self.spray_accel = spray_accel
        self.spray_accel_above = spray_accel_above
        self.terrain = terrain
        self.terrain_tau = terrain_tau_s
        self.max_vz = max_vz
        self._zf: float | None = None  # terrain-following height, low-passed and rate-limited
        self._zfloor: float | None = None  # look-ahead floor, rate-limited
        self.acceptance = acceptance_m
        self.max_lead = max_lead_m
        n = len(clean)
        self.cum = [0.0]
        for i in range(1, n):
            a, b = clean[i - 1], clean[i]
            self.cum.append(self.cum[-1] + math.sqrt((b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2 + (b[2] - a[2]) ** 2))
        self.total = self.cum[-1]
        # allowed speed at each vertex (end: 0)
        self.v_vertex = [speed] * n
        if n > 1:
            self.v_vertex[-1] = 0.0
        for i in range(1, n - 1):
            a, b, c = clean[i - 1], clean[i], clean[i + 1]
            d1 = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
            d2 = (c[0] - b[0], c[1] - b[1], c[2] - b[2])
            n1, n2 = math.sqrt(sum(x * x for x in d1)), math.sqrt(sum(x * x for x in d2))
            cosang = (d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]) / (n1 * n2)
            self.v_vertex[i] = speed if cosang > 0.985 else max(corner_speed, speed * max(0.0, cosang))
        # cruise speed per segment: the vertical component within the climb / descent limits
        self.v_seg = []
        for i in range(n - 1):
            a, b = clean[i], clean[i + 1]
            L = self.cum[i + 1] - self.cum[i]
            vz_frac = (b[2] - a[2]) / L if L > 0 else 0.0
            lim = max_up if vz_frac > 0 else max_down
            v_i = min(speed, clean_speeds[i])
            self.v_seg.append(min(v_i, lim / abs(vz_frac)) if abs(vz_frac) > 1e-6 else v_i)
        for i in range(1, n - 1):
            self.v_vertex[i] = min(self.v_vertex[i], self.v_seg[i - 1], self.v_seg[i])
        for i in stop_at:  # come to rest there (e.g. before a run-in along a row)
            self.v_vertex[i] = 0.0
        self.s = 0.0
        self.v = 0.0
        self.seg = 0
        self._q: list[float] = []
        if terrain is not None and self.total > 0.0:
            self._build_lookahead(speed, accel, max_vz, lookahead_s, lookahead_m, climb_frac, floor_margin_frac)
        self._last_z: float | None = None
        self.sp: Vec3 = self._at(0.0)
        self.vff: Vec3 = (0.0, 0.0, 0.0)
        #: acceleration feed-forward of the last update, m/s² ENU
        self.aff: Vec3 = (0.0, 0.0, 0.0)
        self.flow = self.flows[0]

    def _build_lookahead(self, speed: float, accel: float, max_vz: float, lookahead_s: float,
                         lookahead_m: float | None, climb_frac: float, floor_margin_frac: float) -> None:
        """Sample the demanded height along the path: ``_q[i] = z_d(s_i) - k s_i`` (see the module doc)."""
        self.lookahead = lookahead_m if lookahead_m is not None else speed * lookahead_s + speed * speed / (2.0 * accel)
        self._k = climb_frac * max_vz / speed
        heights = [abs(p[2]) for p in self.points]
        self._margin = floor_margin_frac * (sum(heights) / len(heights))
        n = int(math.ceil(self.total / _PROFILE_DS)) + 1
        ds = self.total / (n - 1)
        self._ds = ds
        self._nw = max(1, int(math.ceil(self.lookahead / ds)))
        seg = self.seg
        q = []
        for i in range(n):
            si = i * ds
            q.append(self._at(si)[2] - self._k * si)
        self.seg = seg
        self._q = q

    def terrain_floor(self, s: float) -> float:
        """Lowest carrot z (m ENU) at path position ``s`` that still climbs over the terrain ahead in time."""
        q = self._q
        if not q:
            return -math.inf
        i0 = min(len(q) - 1, max(0, int(math.ceil(s / self._ds - 1e-9))))
        return max(q[i0:i0 + self._nw + 1]) + self._k * s - self._margin

    def _at(self, s: float) -> Vec3:
        cum = self.cum
        i = self.seg
        while i < len(cum) - 2 and s > cum[i + 1]:
            i += 1
        self.seg = i
        if len(cum) == 1:
            x, y, z = self.points[0]
        else:
            a, b = self.points[i], self.points[i + 1]
            L = cum[i + 1] - cum[i]
            f = 0.0 if L <= 0 else min(1.0, max(0.0, (s - cum[i]) / L))
            x = a[0] + f * (b[0] - a[0])
            y = a[1] + f * (b[1] - a[1])
            z = a[2] + f * (b[2] - a[2])
        if self.terrain is not None:
            z += self.terrain(x, y)
        return (x, y, z)

    def remaining(self, back_m: float = 0.0) -> tuple[list[Vec3], list[float]]:
        """The rest of the path from ``back_m`` metres behind the carrot (not before the start of
        its segment): (points as given, i.e. terrain-relative z if ``terrain``, flows per segment).
        A breakpoint: the path a resumed job flies."""
        cum = self.cum
        if len(cum) == 1:
            return [self.points[0]], []
        i = self.seg
        s = max(cum[i], self.s - back_m)
        a, b = self.points[i], self.points[i + 1]
        seg_len = cum[i + 1] - cum[i]
        f = 0.0 if seg_len <= 0 else min(1.0, (s - cum[i]) / seg_len)
        start = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]))
        return [start, *self.points[i + 1:]], list(self.flows[i:])

    def from_s(self, s: float) -> tuple[list[Vec3], list[float]]:
        """The rest of the path from arc length ``s`` (m): (points as given, flows per segment)."""
        cum = self.cum
        if len(cum) == 1:
            return [self.points[0]], []
        s = min(max(s, 0.0), self.total)
        i = 0
        while i < len(cum) - 2 and s > cum[i + 1]:
            i += 1
        a, b = self.points[i], self.points[i + 1]
        seg_len = cum[i + 1] - cum[i]
        f = 0.0 if seg_len <= 0 else min(1.0, (s - cum[i]) / seg_len)
        start = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]))
        return [start, *self.points[i + 1:]], list(self.flows[i:])

    def project(self, pos: Vec3, back: int = 3) -> tuple[float, float]:
        """(arc length m, horizontal distance m) of the point of the path nearest to ``pos`` (ENU), searched on
        the carrot's segment and the ``back`` segments before it (the vehicle trails the carrot)."""
        pts, cum = self.points, self.cum
        best_s, best_d2 = 0.0, math.inf
        px, py = pos[0], pos[1]
        for i in range(max(0, self.seg - back), min(self.seg + 1, len(pts) - 1)):
            ax, ay = pts[i][0], pts[i][1]
            dx, dy = pts[i + 1][0] - ax, pts[i + 1][1] - ay
            l2 = dx * dx + dy * dy
            u = ((px - ax) * dx + (py - ay) * dy) / l2 if l2 > 0.0 else 0.0
            u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
            ex, ey = ax + u * dx - px, ay + u * dy - py
            d2 = ex * ex + ey * ey
            if d2 < best_d2:
                best_d2 = d2
                best_s = cum[i] + u * (cum[i + 1] - cum[i])
        return best_s, math.sqrt(best_d2)

    def flow_at(self, s: float) -> float:
        """The flow of the segment at arc length ``s`` (m); 0 beyond the end."""
        cum = self.cum
        if s < 0.0 or s >= self.total or len(cum) < 2:
            return 0.0
        lo, hi = 0, len(cum) - 2
        while lo < hi:  # the last segment whose start is <= s
            mid = (lo + hi + 1) // 2
            if cum[mid] <= s:
                lo = mid
            else:
                hi = mid - 1
        return self.flows[lo]

    def direction_at(self, s: float) -> tuple[float, float]:
        """Horizontal unit direction of the path at arc length ``s`` (the segment there)."""
        cum = self.cum
        i = 0
        while i < len(cum) - 2 and s > cum[i + 1]:
            i += 1
        a, b = self.points[i], self.points[min(i + 1, len(self.points) - 1)]
        dx, dy = b[0] - a[0], b[1] - a[1]
        n = math.hypot(dx, dy)
        return (dx / n, dy / n) if n > 0.0 else (1.0, 0.0)

    @property
    def end(self) -> Vec3:
        """Final point (ENU, with the terrain height added if terrain-relative)."""
        x, y, z = self.points[-1]
        return (x, y, z + (self.terrain(x, y) if self.terrain is not None else 0.0))

    def update(self, dt: float, pos: Vec3) -> tuple[Vec3, Vec3, bool]:
        """Advance by ``dt`` s given the vehicle position; returns (setpoint, velocity feed-forward, done)."""
        sp = self.sp
        lead = math.sqrt((sp[0] - pos[0]) ** 2 + (sp[1] - pos[1]) ** 2 + (sp[2] - pos[2]) ** 2)
        # allowed speed: the segment's cruise, the next vertices' limits, acceleration ramp
        v_allow = self.v_seg[self.seg] if self.v_seg else self.speed
        cum = self.cum
        for j in range(self.seg + 1, len(cum)):
            d = cum[j] - self.s
            if d < 0.0:
                continue
            vj = self.v_vertex[j]
            v_lim = math.sqrt(vj * vj + 2.0 * self.accel * d)
            if v_lim < v_allow:
                v_allow = v_lim
            if vj <= 0.0 or d > 3.0 * self.speed * self.speed / self.accel + 1.0:
                break
        if lead > self.max_lead:
            v_allow = 0.0
        v = self.v
        dv = self.accel * dt
        up = dv
        if self.flows[self.seg] > 0.0 and v >= self.spray_accel_above and self.spray_accel < self.accel:
            up = self.spray_accel * dt
        v = min(v_allow, v + up) if v < v_allow else max(v_allow, v - 2.0 * dv)
        self.v = v
        self.s = min(self.total, self.s + v * dt)
        new = self._at(self.s)
        if self.terrain is not None:
            # the terrain under the carrot is rough (a DSM): follow it through a first-order
            # low-pass with a climb-rate limit, never differentiate it twice
            zt = new[2]
            zf = self._zf
            if zf is None:
                zf = zt
            elif dt > 0.0:
                dz = dt / (self.terrain_tau + dt) * (zt - zf)
                lim = self.max_vz * dt
                zf += lim if dz > lim else (-lim if dz < -lim else dz)
            self._zf = zf
            if self._q:
                # look-ahead floor: climb (rate-limited) before a terrain step instead of into it
                floor = self.terrain_floor(self.s)
                zl = self._zfloor
                if zl is None or dt <= 0.0:
                    zl = floor
                else:
                    lim = self.max_vz * dt
                    d = floor - zl
                    zl += lim if d > lim else (-lim if d < -lim else d)
                self._zfloor = zl
                if zl > zf:
                    zf = zl
            new = (new[0], new[1], zf)
        if dt > 0.0:
            vff = ((new[0] - sp[0]) / dt, (new[1] - sp[1]) / dt, (new[2] - sp[2]) / dt)
            o = self.vff
            self.aff = ((vff[0] - o[0]) / dt, (vff[1] - o[1]) / dt,
                        0.0 if self.terrain is not None else (vff[2] - o[2]) / dt)
        else:
            vff = self.vff
        self.vff = vff
        self.sp = new
        self.flow = self.flows[min(self.seg, len(self.flows) - 1)]
        done = False
        if self.s >= self.total - 1e-9:
            e = new  # the end point (terrain-following height as filtered)
            done = math.sqrt((e[0] - pos[0]) ** 2 + (e[1] - pos[1]) ** 2 + (e[2] - pos[2]) ** 2) <= self.acceptance
            self.flow = 0.0 if self.total > 0 else self.flow
        return new, vff, done
