"""The spray budget: where every litre the nozzles emitted went (docs/budget.md). Plain numpy, world ENU, L.

Per landed parcel of :func:`~vinecli.spray.deposition.transport` (one nozzle × size class × 0.04 s):

1. **evaporated** in flight over its fall time (d² law, :mod:`vinecli.spray.evaporation`) when the
   air's temperature and humidity are given;
2. **canopy**: what is left crosses the hedges its landing disc and path overlap and is captured
   there (:mod:`vinecli.spray.interception`; its speed through the foliage and its slant are the
   landing velocity the transport computed: fall through the downwash, wind, relaxation);
3. the rest reaches the ground: **in the field**, **off the field** within ``domain_m`` of it, or
   **airborne out** of that domain (:mod:`vinecli.spray.drift`).

The five shares add up to the emitted volume by construction (``balance_error`` is the rounding).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.geometry import Polyline, segments
from vinecli.spray.canopy import Canopy
from vinecli.spray.deposition import FAR_WALL_JET
from vinecli.spray.downwash import wake_velocity
from vinecli.spray.drift import drift_curve, drift_frames, field_polygon, field_split
from vinecli.spray.evaporation import evaporation_constant, remaining_fraction
from vinecli.spray.interception import annulus_cdf, capture_fraction, impaction_efficiency, stokes_number
from vinecli.spray.nozzle_pattern import inner_radius
from vinecli.spray.wake import plume_radius_at

__all__ = ["BudgetConfig", "SprayBudget", "spray_budget"]

ACROSS = (-0.25, 0.25)  # where across a hedge (share of its width) its deposit is put
FRACTIONS = ("canopy", "ground_in_field", "ground_off_field", "airborne_out", "evaporated")


@dataclass(frozen=True)
class BudgetConfig:
    """Where the drift curve is read and how far the drift domain reaches."""

    drift_distances_m: tuple[float, ...] = (1.0, 3.0, 5.0, 10.0, 15.0, 20.0, 30.0, 50.0)
    drift_band_m: float = 1.0  # width of each distance band, m
    domain_m: float = 50.0  # the drift domain reaches this far beyond the field, m
    central_share: float = 0.5  # share of the last row's length (its middle) the curve averages over
    nodes: int = 6  # quadrature nodes across a hedge's shadow
    merge_s: float = 0.2  # consecutive emission groups merged over this much release time (same nozzle, class)


@dataclass
class SprayBudget:
    """Volumes (L) by destination, per-row canopy deposit, the drift curve and per-parcel figures for the maps."""

    emitted_l: float
    canopy_l: float
    ground_in_field_l: float
    ground_off_field_l: float
    airborne_out_l: float
    evaporated_l: float
    row_canopy_l: np.ndarray  # (rows,) L captured by each row's hedge
    drift: list[dict[str, float]]
    parts: np.ndarray  # (5, parcels) L of each (merged) parcel by destination, in the order of FRACTIONS
    group: np.ndarray  # (parcels,) emission group of each (merged) parcel (its path_xy row)
    canopy_points: np.ndarray  # (3, k) x, y (m ENU), L: where on the hedges the captured volume sits (maps)
    downwind_normal: tuple[float, float] | None
    calm: bool
    last_rows: list[int | None] = field(default_factory=list)
    evaporation: bool = False
    #: per parcel of the transport (its order): the share the canopy caught while it came down in a wake (the
    #: primaries' whole catch; the wall jet's drops before the outwash lifted them; 0 for the others), 0..1
    caught_in_wake: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def fractions(self) -> dict[str, float]:
        """Each destination's share of the emitted volume (0 when nothing was emitted)."""
        e = self.emitted_l
        vals = (self.canopy_l, self.ground_in_field_l, self.ground_off_field_l, self.airborne_out_l, self.evaporated_l)
        return {k: (v / e if e > 0 else 0.0) for k, v in zip(FRACTIONS, vals, strict=True)}

    @property
    def balance_error(self) -> float:
        """|1 - sum of the fractions| (rounding only)."""
        if self.emitted_l <= 0:
            return 0.0
        return abs(1.0 - sum(self.fractions.values()))

    @property
    def captured(self) -> np.ndarray:
        """(parcels,) L on the canopy."""
        return self.parts[0]

    @property
    def landed(self) -> np.ndarray:
        """(parcels,) L that did not evaporate (canopy + ground + airborne out)."""
        return self.parts[:4].sum(axis=0)

    def drift_at(self, distance_m: float) -> float:
        """Drift deposit at ``distance_m`` (one of the curve's distances), % of applied; NaN if absent."""
        for p in self.drift:
            if abs(p["distance_m"] - distance_m) < 1e-9:
                return p["percent_of_applied"]
        return math.nan


def _row_coords(x: np.ndarray, y: np.ndarray, line: Polyline) -> tuple[np.ndarray, ...]:
    """Per point: signed distance to the polyline (left of its direction positive), arc length of the nearest
    point, the unit normal (left) of the nearest segment, and the polyline's length."""
    best = np.full(x.shape, np.inf)
    s_signed = np.zeros(x.shape)
    arc = np.zeros(x.shape)
    nx = np.zeros(x.shape)
    ny = np.zeros(x.shape)
    s0 = 0.0
    for seg in segments(line, len2="hypot"):
        if seg.length <= 0:
            continue
        u = seg.fraction(x, y)
        d = seg.distance(x, y, seg.clamp(u))
        better = d < best
        best = np.where(better, d, best)
        lx, ly = -seg.dy / seg.length, seg.dx / seg.length
        s_signed = np.where(better, (x - seg.ax) * lx + (y - seg.ay) * ly, s_signed)
        arc = np.where(better, seg.start + u * seg.length, arc)
        nx = np.where(better, lx, nx)
        ny = np.where(better, ly, ny)
        s0 = seg.start + seg.length
    return s_signed, arc, nx, ny, np.full(x.shape, s0)


# parameters: the parcels' arrays the capture model reads (position, size, volume, velocity, impaction
# efficiency), one value per parcel each
def _interception(canopy: Canopy, x: np.ndarray, y: np.ndarray, radius: np.ndarray, avail: np.ndarray,
                  vx: np.ndarray, vy: np.ndarray, vz: np.ndarray, eff: np.ndarray, nodes: int,
                  plume: tuple[np.ndarray, ...] | None = None, wake: tuple[np.ndarray, ...] | None = None,
                  downwash: Callable[[float, np.ndarray], np.ndarray] | None = None,
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(captured L per parcel, captured L per row, canopy points (3, k): x, y, L on the hedges).

    A pair's captured volume sits on its hedge at the foot of the parcel's centre on the row line,
    spread evenly over :data:`ACROSS` points across the hedge's width."""
    captured = np.zeros(x.size)
    per_row = np.zeros(len(canopy.rows))
    points: list[np.ndarray] = []
    prof = np.asarray(canopy.profile)
    speed_h = np.hypot(vx, vy)
    for h in canopy.hedges:
        if h.lad_m2m3 <= 0 or h.width_m <= 0 or h.depth_m <= 0 or h.row >= len(canopy.rows):
            continue
        line = canopy.rows[h.row]
        if len(line) < 2:
            continue
        pts = np.asarray(line, dtype=np.float64)
        reach_max = radius + 0.5 * h.width_m + speed_h / vz * h.top_m  # no path slants more than this
        box = ((x > pts[:, 0].min() - reach_max) & (x < pts[:, 0].max() + reach_max)
               & (y > pts[:, 1].min() - reach_max) & (y < pts[:, 1].max() + reach_max) & (avail > 0))
        cand = np.flatnonzero(box)
        if cand.size == 0:
            continue
        s_c, arc_c, nx_c, ny_c, len_c = _row_coords(x[cand], y[cand], line)
        k_c = (vx[cand] * nx_c + vy[cand] * ny_c) / vz[cand]  # cross-row slope of the path, m per m of fall
        reach = radius[cand] + 0.5 * h.width_m + np.abs(k_c) * h.top_m
        ok = (np.abs(s_c) < reach) & (arc_c > -radius[cand]) & (arc_c < len_c + radius[cand])
        if not ok.any():
            continue
        near = cand[ok]
        s, arc, length, k = s_c[ok], arc_c[ok], len_c[ok], k_c[ok]
        r = np.maximum(radius[near], 1e-3)
        ring = plume[3][near] if plume is not None and len(plume) > 3 else None
        inner = inner_radius(r, ring)  # a hollow cone's annulus (spray/nozzle_pattern.py), None: discs
        along = annulus_cdf(length - arc, r, inner) - annulus_cdf(-arc, r, inner)
        sec = np.sqrt(1.0 + (speed_h[near] / vz[near]) ** 2)
        diverge = 0.0
        if plume is not None:  # the plume narrows upwards: paths to the footprint's edge diverge from above
            reach, wake_var, rel = (a[near] for a in plume[:3])
            r_top = plume_radius_at(reach, wake_var, radius[near], rel, h.top_m)
            diverge = np.where(rel > h.top_m, (radius[near] - r_top) / max(h.top_m, 1e-3), 0.0)
        wake_near = None
        if wake is not None and downwash is not None:  # the wake entering this hedge's top
            tau, v_h, v_t, leaf_w = (a[near] for a in wake)
            wake_near = (tau, v_h, v_t, downwash(h.top_m, near), leaf_w)
        frac = capture_fraction(s, r, k, sec, eff[near], canopy.g_factor, h.width_m, h.base_m, h.top_m,
                                h.lad_m2m3, prof, nodes, diverge, wake_near, inner)
        got = np.minimum(avail[near] * along * frac, avail[near] - captured[near])
        captured[near] += got
        per_row[h.row] += float(got.sum())
        fx, fy = x[near] - s * nx_c[ok], y[near] - s * ny_c[ok]
        for c in ACROSS:
            points.append(np.stack([fx + c * h.width_m * nx_c[ok], fy + c * h.width_m * ny_c[ok], got / len(ACROSS)]))
    return captured, per_row, np.concatenate(points, axis=1) if points else np.zeros((3, 0))


@dataclass
class _Merged:
    """Parcels with consecutive emission groups merged (volume-weighted), the budget's working set."""

    x: np.ndarray
    y: np.ndarray
    vol: np.ndarray
    cls: np.ndarray
    radius: np.ndarray
    t_fall: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    vz: np.ndarray
    group: np.ndarray
    reach: np.ndarray
    wake_var: np.ndarray
    release_h: np.ndarray
    wake_vi: np.ndarray
    wake_zeta0: np.ndarray
    wake_bend: np.ndarray
    rotor_radius_m: float = 0.0
    #: the wall jet's far-field parcels: the (merged) primary each stands for, -1 for all others
    wall_source: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    primaries: int = 0  # the first ``primaries`` parcels are the (merged) primaries
    #: each original parcel's row here (the primaries merged, the far field's kept in order)
    row_of: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    #: a hollow cone's ring: the annulus's mean radius, m (0: a disc; spray/nozzle_pattern.py)
    ring_r: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def downwash_at(self, z_m: float, index: np.ndarray) -> np.ndarray:
        """The wake's downward speed (m/s) ``z_m`` above the ground where the parcels ``index`` fell through it."""
        zeta = self.wake_zeta0[index] + np.maximum(self.release_h[index] - z_m, 0.0)
        return wake_velocity(zeta, self.wake_vi[index], max(self.rotor_radius_m, 1e-6), bending=self.wake_bend[index])


def _merge(p: object, group_s: float, merge_s: float) -> _Merged:
    """Merge the primary parcels of the same nozzle and size class released within ``merge_s`` of each other;
    the others (the outwash's, already merged) are kept. Landing points, radii, fall times, velocities:
    volume-weighted means; group: the first."""
    n = int(getattr(p, "primaries", 0))
    group = np.asarray(p.group, dtype=np.int64)  # type: ignore[attr-defined]
    vol = np.asarray(p.vol, dtype=np.float64)  # type: ignore[attr-defined]
    names = ("x", "y", "radius", "t_fall", "vx_land", "vy_land", "vz_land", "reach", "wake_var", "release_h", "wake_vi",
             "wake_zeta0", "wake_bend")
    arrays = [np.asarray(getattr(p, k, np.zeros(0)), dtype=np.float64) for k in names]
    if arrays[-2].size != group.size:  # parcels without the footprint's parts: the disc is the plume at every height
        arrays[-6:] = [arrays[2]] + [np.zeros(group.size)] * 5
    if arrays[-1].size != group.size:  # a wake in still air
        arrays[-1] = np.zeros(group.size)
    radius_m = float(getattr(p, "rotor_radius_m", 0.0))
    cls = np.asarray(p.cls, dtype=np.int64)  # type: ignore[attr-defined]
    kind = np.asarray(getattr(p, "far_kind", np.zeros(0)), dtype=np.int64)
    source = np.asarray(getattr(p, "source", np.zeros(0)), dtype=np.int64)
    wall = np.full(group.size, -1, dtype=np.int64)
    if kind.size == group.size and source.size == group.size:
        wall = np.where((kind == FAR_WALL_JET) & (source >= 0), source, -1)
    span = max(1, int(round(merge_s / group_s)))
    ring = np.asarray(getattr(p, "ring_r", np.zeros(0)), dtype=np.float64)
    ring = ring if ring.size == group.size else np.zeros(group.size)
    if n <= 0 or span <= 1 or group.size == 0:
        return _Merged(*arrays[:2], vol, cls, *arrays[2:7], group, *arrays[7:], radius_m, wall, max(n, 0),
                       np.arange(group.size), ring)
    per_group = n // (int(group[:n].max()) + 1)
    idx = np.arange(n)
    key = (group[:n] // span) * per_group + idx % per_group
    uk, first, inv = np.unique(key, return_index=True, return_inverse=True)
    w = vol[:n]
    wsum = np.bincount(inv, weights=w)
    safe = np.where(wsum > 0, wsum, 1.0)
    out = []
    for a in [*arrays, ring]:
        m = np.bincount(inv, weights=a[:n] * w) / safe
        plain = np.bincount(inv, weights=a[:n]) / np.bincount(inv)
        out.append(np.concatenate([np.where(wsum > 0, m, plain), a[n:]]))
    ring = out.pop()
    # the far field's parcels keep their order after the merged primaries; their sources are merged with them
    wall_far = wall[n:]
    wall_far = np.where(wall_far >= 0, inv[np.clip(wall_far, 0, n - 1)], -1)
    return _Merged(out[0], out[1], np.concatenate([wsum, vol[n:]]), np.concatenate([cls[:n][first], cls[n:]]),
                   out[2], out[3], out[4], out[5], out[6], np.concatenate([group[:n][first], group[n:]]), *out[7:],
                   radius_m, np.concatenate([np.full(uk.size, -1, dtype=np.int64), wall_far]), int(uk.size),
                   np.concatenate([inv, uk.size + np.arange(group.size - n)]), ring)


def _canopy_first(p: _Merged, canopy: Canopy, landed: np.ndarray, vz: np.ndarray, eff: np.ndarray,
                  wake: tuple[np.ndarray, ...], nodes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The canopy's catch (:func:`_interception`), in the order the drops meet it: the wall jet's drops came down in
    their primary parcel's wake and crossed its hedges first (their primary carries them through the canopy, and
    they keep the share of its catch), then the far field's parcels meet the hedges where they land. Also returns
    each parcel's share caught on the way down in a wake (the primaries' whole catch)."""
    n = p.primaries
    first, rest = np.arange(n), np.arange(n, landed.size)

    def run(sel: np.ndarray, avail: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return _interception(canopy, p.x[sel], p.y[sel], p.radius[sel], avail, p.vx[sel], p.vy[sel], vz[sel],
                             eff[sel], nodes, (p.reach[sel], p.wake_var[sel], p.release_h[sel], p.ring_r[sel]),
                             tuple(a[sel] for a in wake), lambda z, i: p.downwash_at(z, sel[i]))

    src = p.wall_source[rest]
    carried = np.bincount(src[src >= 0], weights=landed[rest][src >= 0], minlength=n)[:n] if n else np.zeros(0)
    c1, r1, pts1 = run(first, landed[first] + carried)
    share = np.divide(c1, landed[first] + carried, out=np.zeros(n), where=(landed[first] + carried) > 0)
    pre = np.where(src >= 0, landed[rest] * share[np.clip(src, 0, max(n - 1, 0))], 0.0) if n else np.zeros(rest.size)
    c2, r2, pts2 = run(rest, landed[rest] - pre)
    captured = np.concatenate([share * landed[first], pre + c2])
    on_the_way = np.concatenate([share, np.divide(pre, landed[rest], out=np.zeros(rest.size), where=landed[rest] > 0)])
    return captured, r1 + r2, np.concatenate([pts1, pts2], axis=1), on_the_way


# parameters: the parcels and their size classes, the rows and the field's wind, then the air, the options and
# gravity with defaults
def spray_budget(parcels: object, diam_m: np.ndarray, v_t: np.ndarray, canopy: Canopy | None,
                 rows: Sequence[Polyline], spacing_m: float, applied_lpha: float, wind_xy: tuple[float, float],
                 air: tuple[float, float] | None = None, config: BudgetConfig = BudgetConfig(),
                 g: float = STANDARD_GRAVITY) -> SprayBudget:
    """The budget of ``parcels`` (:class:`~vinecli.spray.deposition.Parcels` with landing velocities).

    ``diam_m``, ``v_t``: the size classes' diameters (m) and terminal velocities (m/s); ``air``:
    (temperature °C, relative humidity %) or None (no evaporation); ``wind_xy``: the mean horizontal
    wind while spraying (m/s ENU, sets the downwind side); ``applied_lpha``: the rate asked in the field.
    """
    p = _merge(parcels, float(getattr(parcels, "group_s", 0.04)), config.merge_s)
    vol, x, y, cls, radius = p.vol, p.x, p.y, p.cls, p.radius
    d0, vt = np.asarray(diam_m)[cls], np.asarray(v_t)[cls]
    emitted = float(getattr(parcels, "emitted_l", vol.sum()))
    if air is not None and vol.size:
        lam = evaporation_constant(np.asarray(diam_m), np.asarray(v_t), air[0], air[1])[cls]
        landed = vol * remaining_fraction(d0, lam, p.t_fall)
    else:
        landed = vol.copy()
    captured = np.zeros(vol.size)
    on_the_way = np.zeros(vol.size)
    points = np.zeros((3, 0))
    per_row = np.zeros(len(canopy.rows) if canopy is not None else 0)
    if canopy is not None and canopy.has_foliage and vol.size:
        vz = np.maximum(p.vz, 1e-3)
        speed = np.sqrt(p.vx * p.vx + p.vy * p.vy + vz * vz)
        eff = impaction_efficiency(stokes_number(vt / g, speed, canopy.leaf_width_m))
        wake = (vt / g, np.hypot(p.vx, p.vy), vt, np.full(vt.size, canopy.leaf_width_m))
        captured, per_row, points, on_the_way = _canopy_first(p, canopy, landed, vz, eff, wake, config.nodes)
    ground = landed - captured
    cone = float(np.median(radius)) if radius.size else 0.5
    fieldg = field_polygon(rows, spacing_m, np.asarray(parcels.path_xy), cone)  # type: ignore[attr-defined]
    infield, offfield, beyond = field_split(fieldg, config.domain_m, x, y, radius, ground)
    frames, calm = drift_frames(rows, fieldg, wind_xy, config.central_share)
    # the drift curve is the sprayed product's (ISO 22866 trials measure a tracer, which does not evaporate with the
    # water): each parcel's volume as emitted, less the canopy's share of it
    product = vol * (1.0 - np.divide(captured, landed, out=np.zeros_like(landed), where=landed > 0))
    curve = drift_curve(frames, x, y, radius, product, applied_lpha, config.drift_distances_m, config.drift_band_m)
    # the sum of the parts is the emitted volume: the parcels' volumes add up to it (transport), and each
    # parcel's volume is split exactly into evaporated + captured + in field + off field + beyond
    return SprayBudget(
        emitted_l=emitted, canopy_l=float(captured.sum()), ground_in_field_l=float(infield.sum()),
        ground_off_field_l=float(offfield.sum()), airborne_out_l=float(beyond.sum()),
        evaporated_l=float((vol - landed).sum()), row_canopy_l=per_row, drift=curve,
        parts=np.stack([captured, infield, offfield, beyond, vol - landed]), group=p.group, canopy_points=points,
        downwind_normal=frames[0].normal if frames and not calm else None, calm=calm,
        last_rows=[f.row for f in frames], evaporation=air is not None,
        caught_in_wake=on_the_way[p.row_of] if p.row_of.size else np.zeros(0))
