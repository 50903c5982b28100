"""The spray budget: where every litre the nozzles emitted went (docs/budget.md). Plain numpy, world ENU, L.

Per landed parcel of :func:`~vinecli.physics.deposition.transport` (one nozzle × size class × 0.04 s):

1. **evaporated** in flight over its fall time (d² law, :mod:`vinecli.physics.evaporation`) when the
   air's temperature and humidity are given;
2. **canopy**: what is left crosses the hedges its landing disc and path overlap and is captured
   there (:mod:`vinecli.physics.interception`; its speed through the foliage and its slant are the
   landing velocity the transport computed: fall through the downwash, wind, relaxation);
3. the rest reaches the ground: **in the field**, **off the field** within ``domain_m`` of it, or
   **airborne out** of that domain (:mod:`vinecli.physics.drift`).

The five shares add up to the emitted volume by construction (``balance_error`` is the rounding).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.physics.canopy import Canopy
from vinecli.physics.drift import drift_curve, drift_frames, field_polygon, field_split
from vinecli.physics.evaporation import evaporation_constant, remaining_fraction
from vinecli.physics.interception import capture_fraction, impaction_efficiency, semicircle_cdf, stokes_number

__all__ = ["BudgetConfig", "SprayBudget", "spray_budget"]

Polyline = Sequence[tuple[float, float]]
FRACTIONS = ("canopy", "ground_in_field", "ground_off_field", "airborne_out", "evaporated")


@dataclass(frozen=True)
class BudgetConfig:
    """Where the drift curve is read and how far the drift domain reaches."""

    drift_distances_m: tuple[float, ...] = (1.0, 3.0, 5.0, 10.0, 15.0, 20.0, 30.0, 50.0)
    drift_band_m: float = 1.0  # width of each distance band, m
    domain_m: float = 50.0  # the drift domain reaches this far beyond the field, m
    central_share: float = 0.5  # share of the last row's length (its middle) the curve averages over
    nodes: int = 8  # quadrature nodes across a hedge's shadow


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
    parts: np.ndarray  # (5, parcels) L of each parcel by destination, in the order of FRACTIONS
    shadow: np.ndarray  # (parcels,) share of each parcel's landing disc in the hedges' shadows
    downwind_normal: tuple[float, float] | None
    calm: bool
    last_rows: list[int | None] = field(default_factory=list)
    evaporation: bool = False

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
    pts = np.asarray(line, dtype=np.float64)
    best = np.full(x.shape, np.inf)
    s_signed = np.zeros(x.shape)
    arc = np.zeros(x.shape)
    nx = np.zeros(x.shape)
    ny = np.zeros(x.shape)
    s0 = 0.0
    for (ax, ay), (bx, by) in zip(pts[:-1], pts[1:], strict=True):
        dx, dy = bx - ax, by - ay
        seg = math.hypot(dx, dy)
        if seg <= 0:
            continue
        u = ((x - ax) * dx + (y - ay) * dy) / (seg * seg)
        uc = np.clip(u, 0.0, 1.0)
        d = np.hypot(x - (ax + uc * dx), y - (ay + uc * dy))
        better = d < best
        best = np.where(better, d, best)
        lx, ly = -dy / seg, dx / seg
        s_signed = np.where(better, (x - ax) * lx + (y - ay) * ly, s_signed)
        arc = np.where(better, s0 + u * seg, arc)
        nx = np.where(better, lx, nx)
        ny = np.where(better, ly, ny)
        s0 += seg
    return s_signed, arc, nx, ny, np.full(x.shape, s0)


def _interception(canopy: Canopy, x: np.ndarray, y: np.ndarray, radius: np.ndarray, avail: np.ndarray,
                  vx: np.ndarray, vy: np.ndarray, vz: np.ndarray, eff: np.ndarray, nodes: int,
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(captured L per parcel, captured L per row, share of each parcel's disc in the hedges' shadows)."""
    captured = np.zeros(x.size)
    shadow = np.zeros(x.size)
    per_row = np.zeros(len(canopy.rows))
    prof = np.asarray(canopy.profile)
    speed_h = np.hypot(vx, vy)
    for h in canopy.hedges:
        if h.lad_m2m3 <= 0 or h.width_m <= 0 or h.depth_m <= 0 or h.row >= len(canopy.rows):
            continue
        line = canopy.rows[h.row]
        if len(line) < 2:
            continue
        s, arc, nx, ny, length = _row_coords(x, y, line)
        k = (vx * nx + vy * ny) / vz  # cross-row slope of the path, m per m of fall
        reach = radius + 0.5 * h.width_m + np.abs(k) * h.top_m
        near = (np.abs(s) < reach) & (arc > -radius) & (arc < length + radius) & (avail > 0)
        if not near.any():
            continue
        r = np.maximum(radius[near], 1e-3)
        along = semicircle_cdf((length[near] - arc[near]) / r) - semicircle_cdf(-arc[near] / r)
        sec = np.sqrt(1.0 + (speed_h[near] / vz[near]) ** 2)
        frac = capture_fraction(s[near], r, k[near], sec, eff[near], canopy.g_factor, h.width_m, h.base_m, h.top_m,
                                h.lad_m2m3, prof, nodes)
        kk = k[near]
        s0 = np.minimum(kk * h.base_m, kk * h.top_m) - 0.5 * h.width_m
        s1 = np.maximum(kk * h.base_m, kk * h.top_m) + 0.5 * h.width_m
        shadow[near] += along * (semicircle_cdf((s1 - s[near]) / r) - semicircle_cdf((s0 - s[near]) / r))
        got = np.minimum(avail[near] * along * frac, avail[near] - captured[near])
        captured[near] += got
        per_row[h.row] += float(got.sum())
    return captured, per_row, np.minimum(shadow, 1.0)


def spray_budget(parcels: object, diam_m: np.ndarray, v_t: np.ndarray, canopy: Canopy | None,
                 rows: Sequence[Polyline], spacing_m: float, applied_lpha: float, wind_xy: tuple[float, float],
                 air: tuple[float, float] | None = None, config: BudgetConfig = BudgetConfig(),
                 g: float = STANDARD_GRAVITY) -> SprayBudget:
    """The budget of ``parcels`` (:class:`~vinecli.physics.deposition.Parcels` with landing velocities).

    ``diam_m``, ``v_t``: the size classes' diameters (m) and terminal velocities (m/s); ``air``:
    (temperature °C, relative humidity %) or None (no evaporation); ``wind_xy``: the mean horizontal
    wind while spraying (m/s ENU, sets the downwind side); ``applied_lpha``: the rate asked in the field.
    """
    p = parcels
    vol = np.asarray(p.vol, dtype=np.float64)  # type: ignore[attr-defined]
    x, y = np.asarray(p.x, dtype=np.float64), np.asarray(p.y, dtype=np.float64)  # type: ignore[attr-defined]
    cls = np.asarray(p.cls, dtype=np.int64)  # type: ignore[attr-defined]
    radius = np.asarray(p.radius, dtype=np.float64)  # type: ignore[attr-defined]
    d0, vt = np.asarray(diam_m)[cls], np.asarray(v_t)[cls]
    emitted = float(getattr(p, "emitted_l", vol.sum()))
    if air is not None and vol.size:
        lam = evaporation_constant(np.asarray(diam_m), np.asarray(v_t), air[0], air[1])[cls]
        landed = vol * remaining_fraction(d0, lam, np.asarray(p.t_fall))  # type: ignore[attr-defined]
    else:
        landed = vol.copy()
    captured = np.zeros(vol.size)
    shadow = np.zeros(vol.size)
    per_row = np.zeros(len(canopy.rows) if canopy is not None else 0)
    if canopy is not None and canopy.has_foliage and vol.size:
        vx, vy = np.asarray(p.vx_land), np.asarray(p.vy_land)  # type: ignore[attr-defined]
        vz = np.maximum(np.asarray(p.vz_land), 1e-3)  # type: ignore[attr-defined]
        speed = np.sqrt(vx * vx + vy * vy + vz * vz)
        eff = impaction_efficiency(stokes_number(vt / g, speed, canopy.leaf_width_m))
        captured, per_row, shadow = _interception(canopy, x, y, radius, landed, vx, vy, vz, eff, config.nodes)
    ground = landed - captured
    cone = float(np.median(radius)) if radius.size else 0.5
    fieldg = field_polygon(rows, spacing_m, np.asarray(p.path_xy), cone)  # type: ignore[attr-defined]
    infield, offfield, beyond = field_split(fieldg, config.domain_m, x, y, radius, ground)
    frames, calm = drift_frames(rows, fieldg, wind_xy, config.central_share)
    curve = drift_curve(frames, x, y, radius, ground, applied_lpha, config.drift_distances_m, config.drift_band_m)
    # the sum of the parts is the emitted volume: the parcels' volumes add up to it (transport), and each
    # parcel's volume is split exactly into evaporated + captured + in field + off field + beyond
    return SprayBudget(
        emitted_l=emitted, canopy_l=float(captured.sum()), ground_in_field_l=float(infield.sum()),
        ground_off_field_l=float(offfield.sum()), airborne_out_l=float(beyond.sum()),
        evaporated_l=float((vol - landed).sum()), row_canopy_l=per_row, drift=curve,
        parts=np.stack([captured, infield, offfield, beyond, vol - landed]), shadow=shadow, downwind_normal=frames[0].normal if frames and not calm else None, calm=calm,
        last_rows=[f.row for f in frames], evaporation=air is not None)
