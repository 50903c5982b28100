"""What a field trial's collectors would catch: filter papers in the canopy, Petri dishes on the ground. SI, ENU.

Trials measure deposits on collectors (µL/cm² of collector), not the budget itself; to compare
like with like the model's spray is sampled where the papers put their collectors:

* a horizontal collector at ``(x, y, z)`` (z above the ground) facing up catches the downward volume
  flux there times its collection efficiency (impaction on a collector of width ``width_m``,
  :func:`~vinecli.spray.interception.impaction_efficiency`; a Petri dish on the ground: 1). The
  flux is every parcel's disc (volume spread uniformly over its cone footprint) met at that height
  along the parcel's slanted path, attenuated by the foliage above the collector on that path
  (Beer–Lambert, :mod:`vinecli.spray.interception`). Its lower face catches nothing in this model
  (no upward flux): a paper reporting the mean of both leaf faces is compared with half the upper.
"""

from __future__ import annotations

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.spray.canopy import Canopy
from vinecli.spray.interception import impaction_efficiency, leaf_area_on_path, stokes_number
from vinecli.spray.nozzle_pattern import inner_radius
from vinecli.spray.wake import LEAF_DRAG_COEFFICIENT, mean_speed_through_foliage, plume_radius_at

__all__ = ["UL_PER_CM2", "collector_deposit"]

UL_PER_CM2 = 100.0  # µL/cm² per L/m²


# parameters: the parcels' arrays the collector model reads (position, volume, size, velocity, settling
# speed), one value per parcel each, then the collectors
def collector_deposit(x: np.ndarray, y: np.ndarray, vol: np.ndarray, radius: np.ndarray, vx: np.ndarray,
                      vy: np.ndarray, vz: np.ndarray, v_t: np.ndarray, points: np.ndarray, canopy: Canopy | None,
                      width_m: float | None = 0.12, g: float = STANDARD_GRAVITY,
                      plume: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                      w_top: np.ndarray | None = None, ring_r: np.ndarray | None = None) -> np.ndarray:
    """Deposit (µL/cm²) on the upward face of a collector at each of ``points`` ((m, 3): x, y, z above the ground).

    Parcels: landing centre (m), volume reaching the ground or canopy (L), disc radius (m), velocity on
    landing (m/s, vz down positive), terminal velocity (m/s). ``width_m``: the collector's width for
    its impaction efficiency, None for a dish that catches everything. ``plume``: the footprint's parts
    (reach m, wake variance term m², release height m; :class:`~vinecli.spray.deposition.Parcels`): the plume
    is then narrower at the collector's height; ``w_top``: the wake's speed entering the canopy (m/s), which the
    foliage slows (:mod:`vinecli.spray.wake`); ``ring_r``: the mean radius (m, 0: a disc) of parcels landing on an
    annulus (a hollow cone's ring, :mod:`vinecli.spray.nozzle_pattern`), whose inner radius is ``2 ring_r - r``.
    """
    vz = np.maximum(vz, 1e-3)
    r = np.maximum(radius, 1e-3)
    tau = v_t / g
    v_h = np.sqrt(vx * vx + vy * vy)
    w_top = np.zeros_like(vz) if w_top is None else np.asarray(w_top, dtype=np.float64)
    leaf_w = canopy.leaf_width_m if canopy is not None else 0.12
    out = np.zeros(len(points))
    for i, (px, py, pz) in enumerate(np.asarray(points, dtype=np.float64)):
        rz = r if plume is None else np.maximum(plume_radius_at(*plume[:2], r, plume[2], pz), 1e-3)
        cx, cy = x - vx / vz * pz, y - vy / vz * pz  # where each parcel's disc is at the collector's height
        d2 = (cx - px) ** 2 + (cy - py) ** 2
        inner = inner_radius(rz, ring_r)
        hit = (d2 <= rz * rz) if inner is None else (d2 <= rz * rz) & (d2 >= inner * inner)
        if not hit.any():
            continue
        hole = 0.0 if inner is None else inner[hit] ** 2
        flux = vol[hit] / (np.pi * (rz[hit] ** 2 - hole))  # L/m² of horizontal area
        area_above = np.zeros(int(hit.sum()))
        if canopy is not None:
            for h in canopy.hedges:
                if h.lad_m2m3 <= 0 or pz >= h.top_m:
                    continue
                line = np.asarray(canopy.rows[h.row], dtype=np.float64)
                d = line[-1] - line[0]
                t = d / np.linalg.norm(d)
                nx, ny = -t[1], t[0]
                s_pt = (px - line[0, 0]) * nx + (py - line[0, 1]) * ny  # collector's cross-row offset
                if abs(s_pt) > 0.5 * h.width_m + 5.0:
                    continue
                k = (vx[hit] * nx + vy[hit] * ny) / vz[hit]
                # the path reaches the collector at (s_pt, pz); in the frame of leaf_area_on_path, x(z) = s - k z,
                # that is s = s_pt + k pz; only the foliage above pz counts
                area = leaf_area_on_path(s_pt + k * pz, k, h.width_m, max(h.base_m, pz), h.top_m, h.lad_m2m3,
                                         np.asarray(canopy.profile) if len(canopy.profile) == 1 else
                                         _profile_above(canopy.profile, h.base_m, h.top_m, pz))
                sec = np.sqrt(1.0 + (vx[hit] ** 2 + vy[hit] ** 2) / vz[hit] ** 2)
                area_above += sec * area
        # the foliage above filters the drops (at the wake's mean speed in it) and slows the wake reaching the collector
        w_mean = mean_speed_through_foliage(w_top[hit], area_above)
        e_path = impaction_efficiency(stokes_number(tau[hit], np.sqrt(v_h[hit] ** 2 + (v_t[hit] + w_mean) ** 2), leaf_w))
        trans = np.exp(-(canopy.g_factor if canopy is not None else 0.5) * e_path * area_above)
        w_here = w_top[hit] * np.exp(-LEAF_DRAG_COEFFICIENT * area_above)
        speed_here = np.sqrt(v_h[hit] ** 2 + (v_t[hit] + w_here) ** 2)
        eff_c = (np.ones(int(hit.sum())) if width_m is None else
                 impaction_efficiency(stokes_number(tau[hit], speed_here, width_m)))
        out[i] = UL_PER_CM2 * float(np.sum(flux * trans * eff_c))
    return out


def _profile_above(profile: tuple[float, ...], base: float, top: float, z: float) -> np.ndarray:
    """The relative LAD profile of the layers above ``z`` (resampled on equal layers from z to the top)."""
    p = np.asarray(profile, dtype=np.float64)
    edges = np.linspace(base, top, p.size + 1)
    zs = np.linspace(max(z, base), top, 4 * p.size + 1)
    mids = 0.5 * (zs[:-1] + zs[1:])
    idx = np.clip(np.searchsorted(edges, mids, side="right") - 1, 0, p.size - 1)
    return p[idx]
