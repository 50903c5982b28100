"""Drops captured by a hedge canopy: Beer–Lambert over the leaf area on the path, times the impaction efficiency.

A drop crossing foliage of leaf area density ``a(z)`` (m²/m³) meets leaves at the rate ``G a`` per metre
of path (``G`` the mean projection of the leaves on the plane normal to the path, 0.5 for a spherical
leaf-angle distribution) and sticks to a leaf it approaches with the collection efficiency ``E``:
it gets through with probability ``exp(-E G ∫ a ds)`` (Beer–Lambert / Monsi & Saeki 1953 extinction,
with the leaf area met per unit path scaled by E as in Raupach et al. 2001, Atmos. Environ. 35:3373,
for particles filtered by vegetation).

Collection efficiency by inertial impaction on leaves of characteristic width ``L``:
``St = τ_p U / L`` with the drop's relaxation time ``τ_p = v_t / g`` and its speed through the foliage
U, and ``E = (St / (St + 0.8))²`` (Peters & Eiden 1992, Atmos. Environ. 26A:2555, used for
vegetation elements by Raupach et al. 2001; Zhang et al. 2001, Atmos. Environ. 35:549, the same form).

Geometry: the hedge is a rectangle in the cross-row plane (width w, foliage from b to H above the
ground). A drop landing at the cross-row coordinate ``s`` (from the row line) with a cross-row slope
``k`` (horizontal metres per metre of fall) was at ``s - k z`` at height z; its path through the
foliage is the part of that line inside the rectangle, lengthened by the 3-D slant ``sec φ``. A
parcel lands uniformly over a disc (the spray cone), whose cross-row marginal is the semicircle
law; :func:`capture_fraction` integrates the capture probability over the hedge's shadow with
``nodes`` midpoints, each weighted by the exact semicircle mass of its sub-interval.
"""

from __future__ import annotations

import numpy as np

__all__ = ["EFFICIENCY_A", "annulus_cdf", "capture_fraction", "impaction_efficiency", "leaf_area_on_path", "semicircle_cdf",
           "stokes_number"]

EFFICIENCY_A = 0.8  # Peters & Eiden 1992


def stokes_number(tau_s: np.ndarray, speed_mps: np.ndarray, leaf_width_m: float) -> np.ndarray:
    """Impaction Stokes number ``τ_p U / L`` (relaxation time s, speed through the foliage m/s, leaf width m)."""
    return np.asarray(tau_s, dtype=np.float64) * np.asarray(speed_mps, dtype=np.float64) / leaf_width_m


def impaction_efficiency(st: np.ndarray, a: float = EFFICIENCY_A) -> np.ndarray:
    """Collection efficiency ``(St/(St + a))²`` of leaves, 0..1 (Peters & Eiden 1992)."""
    s = np.maximum(np.asarray(st, dtype=np.float64), 0.0)
    return (s / (s + a)) ** 2


def semicircle_cdf(u: np.ndarray) -> np.ndarray:
    """CDF of the cross-section of a uniform unit disc along one axis (``u`` in radii): 0 at -1, 1 at +1."""
    x = np.clip(np.asarray(u, dtype=np.float64), -1.0, 1.0)
    return 0.5 + (x * np.sqrt(1.0 - x * x) + np.arcsin(x)) / np.pi


def annulus_cdf(s: np.ndarray, outer: np.ndarray, inner: np.ndarray | None = None) -> np.ndarray:
    """Share of a uniform annulus (radii ``outer``, ``inner`` m; None or 0: a disc) lying below ``s`` (m from its
    centre) along one axis: the outer disc's semicircle law less the inner disc's, by their areas."""
    ro = np.maximum(np.asarray(outer, dtype=np.float64), 1e-12)
    cdf = semicircle_cdf(np.asarray(s) / ro)
    if inner is None:
        return cdf
    ri = np.clip(np.asarray(inner, dtype=np.float64), 0.0, 0.999 * ro)
    ao, ai = ro * ro, ri * ri
    return np.where(ri > 0.0, (ao * cdf - ai * semicircle_cdf(np.asarray(s) / np.maximum(ri, 1e-12))) / (ao - ai), cdf)


def leaf_area_on_path(s: np.ndarray, k: np.ndarray, width: np.ndarray, base: np.ndarray, top: np.ndarray,
                      lad: np.ndarray, profile: np.ndarray) -> np.ndarray:
    """∫ a dz (m²/m² of path cross-section, before the slant) along ``x(z) = s - k z`` through the hedge.

    Arrays broadcast together (m, m/m, m, m, m, m²/m³); ``profile`` (n,) relative LAD of equal layers
    from base to top (mean 1). The line is inside the hedge where ``|s - k z| <= w/2``.
    """
    s, k, w, b, h, a = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (s, k, width, base, top, lad)))
    half = 0.5 * w
    kk = np.where(np.abs(k) < 1e-9, 1e-9, k)
    z_a = (s - half) / kk
    z_b = (s + half) / kk
    lo = np.minimum(z_a, z_b)
    hi = np.maximum(z_a, z_b)
    vertical = np.abs(k) < 1e-9
    inside = np.abs(s) <= half
    lo = np.where(vertical, np.where(inside, -np.inf, np.inf), lo)
    hi = np.where(vertical, np.where(inside, np.inf, -np.inf), hi)
    n = len(profile)
    dz = (h - b) / n
    total = np.zeros(s.shape)
    for j, rel in enumerate(profile):
        z0 = b + j * dz
        z1 = z0 + dz
        overlap = np.clip(np.minimum(hi, z1) - np.maximum(lo, z0), 0.0, None)
        total += a * rel * overlap
    return total


# parameters: the formula's inputs (module doc): per (parcel, hedge) pair arrays of the parcel and the
# hedge, one value per pair each, evaluated in one vectorised pass
def capture_fraction(s_c: np.ndarray, radius: np.ndarray, k: np.ndarray, sec: np.ndarray, eff: np.ndarray,
                     g_factor: float, width: np.ndarray, base: np.ndarray, top: np.ndarray, lad: np.ndarray,
                     profile: np.ndarray, nodes: int = 8, diverge: np.ndarray | float = 0.0,
                     wake: tuple[np.ndarray, ...] | None = None, inner: np.ndarray | None = None) -> np.ndarray:
    """Share of a parcel's volume captured by one hedge, 0..1 (arrays over (parcel, hedge) pairs).

    ``s_c``: cross-row coordinate of the parcel's landing disc centre from the row line (m, along the
    row normal), ``radius``: disc radius (m), ``k``: cross-row slope of the drops' path (along the same
    normal), ``sec``: path length per metre of height, ``eff``: collection efficiency.
    ``diverge``: how much steeper the path of a drop landing at the disc's edge is (m per m of height): the
    plume narrows upwards (:mod:`vinecli.spray.wake`), a drop landing at ``s_c + u r`` crossed the hedge
    along the slope ``k + u · diverge``. ``wake``: (relaxation time s, horizontal speed m/s, fall speed
    without the wake m/s, wake speed entering the foliage m/s, leaf width m): the efficiency is then taken
    per path at the wake's mean speed in the foliage (the leaves' drag slows it,
    :func:`vinecli.spray.wake.mean_speed_through_foliage`) instead of ``eff``. ``inner``: the inner radius (m, 0 for
    a disc) of parcels landing on an annulus (a hollow cone's ring, :mod:`vinecli.spray.nozzle_pattern`).
    """
    from vinecli.spray.wake import mean_speed_through_foliage

    s_c, r, k, sec, eff, w, b, h, a, dv = np.broadcast_arrays(
        *(np.asarray(v, dtype=np.float64) for v in (s_c, radius, k, sec, eff, width, base, top, lad, diverge)))
    r = np.maximum(r, 1e-3)
    half = 0.5 * w
    adv = np.abs(dv)
    k_lo, k_hi = k - adv, k + adv
    s0 = np.minimum(k_lo * b, k_lo * h) - half  # the hedge's shadow on the ground along the drops' paths
    s1 = np.maximum(k_hi * b, k_hi * h) + half
    step = (s1 - s0) / nodes
    out = np.zeros(s_c.shape)
    prof = np.asarray(profile, dtype=np.float64)
    if wake is not None:
        tau, v_h, v_t, w_top, leaf_w = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in wake))
    # the disc's (or annulus's) mass between consecutive nodes' edges: one CDF evaluation per edge
    ri = None if inner is None else np.broadcast_to(np.asarray(inner, dtype=np.float64), s_c.shape)
    cdf = [annulus_cdf(s0 + i * step - s_c, r, ri) for i in range(nodes + 1)]
    for i in range(nodes):
        mass = cdf[i + 1] - cdf[i]
        live = mass > 0.0
        if not live.any():
            continue
        s_mid = s0[live] + (i + 0.5) * step[live]
        u = np.clip((s_mid - s_c[live]) / r[live], -1.0, 1.0)
        kk = k[live] + u * dv[live]
        area = leaf_area_on_path(s_mid, kk, w[live], b[live], h[live], a[live], prof)
        if wake is None:
            e = eff[live]
        else:
            wm = mean_speed_through_foliage(w_top[live], area * sec[live])
            speed = np.sqrt(v_h[live] ** 2 + (v_t[live] + wm) ** 2)
            e = impaction_efficiency(stokes_number(tau[live], speed, leaf_w[live]))
        p = 1.0 - np.exp(-g_factor * e * sec[live] * area)
        out[live] += mass[live] * p
    return out
