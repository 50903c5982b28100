"""The rotor wake that carries the spray: how wide a drop class lands, and how the canopy slows the wake. SI units.

A spray leaves a nozzle as a cone, but its drops do not fly on along the cone: air drag stops their
sideways motion within a short reach, and from then on the rotor wake carries them down. So the
footprint a size class lands on is set by

1. **the ballistic reach** of its drops: leaving the nozzle at the exit speed ``V0 = sqrt(2 Δp / ρ_w)``
   (Bernoulli across the orifice, the sprayer's rated pressure) along a ray of the cone (half angle θ/2), a
   drop slows under the Schiller–Naumann drag of its whole speed (``dv/dt = -v (1 + 0.15 Re^0.687) / τ_St``,
   Re from ``|v|``, :mod:`vinecli.spray.droplets`): it stops ``τ_St ∫_0^{V0} dv / (1 + 0.15 Re(v)^0.687)``
   along the ray, ``sin(θ/2)`` of that sideways (no further than the cone reaches at the ground). Taking the
   sideways speed alone would understate its Reynolds number, hence the drag: 600 µm drops from a 60° cone at
   3 bar stop 1.6 m sideways, not 2.4 m. Fine drops stop within centimetres (145 µm, 60° cone: 0.20 m),
   coarse ones keep their momentum (330 µm: 0.68 m; a boom nozzle's 110° fan at 0.5 m spreads ~0.7 m each
   side: the same scale);
2. **the wake's turbulent spreading** while it carries them: the vehicle's rotors make one wake that
   contracts to half the disc area below the rotors (momentum theory: radius ``R_w = R_eq / √2`` with
   ``R_eq = R √n``, Leishman 2006, ch. 2) and mixes like a round turbulent jet (Bauersfeld et al. 2024,
   arXiv 2403.13321: the downwash of multirotors is a round jet a few diameters below them). A round
   jet's eddy viscosity is ``ν_T = 0.028 U_c r_½`` (its turbulent Reynolds number U_c r_½ / ν_T ≈ 35:
   Pope 2000, *Turbulent Flows*, ch. 5); a drop the wake carries a distance ``s`` (the air's share of its
   fall, ``h - v_t t``) spreads with variance ``σ² = 2 ν_T t = 0.056 r_½ s`` across each axis.

The class's footprint is the disc of the same variance as reach and spreading together: radius
``sqrt(r_b² + 4 σ²)`` (a uniform disc of radius r has variance r²/4 along an axis). The drops reach that
disc along straight paths from the nozzle (the interception's path slopes, :mod:`vinecli.spray.interception`).

**Porous hedges slow the wake.** Inside foliage the wake loses momentum to the leaves' drag:
``U dU/ds = -C_d a U²`` gives ``U = U_0 exp(-C_d ∫a ds)`` along the path, with the leaf drag coefficient
``C_d = 0.2`` (the value of canopy-flow models for leaves, e.g. Katul et al. 2004, Boundary-Layer Meteorol.
113:81; Shaw & Schumann 1992). A drop crosses the foliage at the path's mean wake speed
``U_0 (1 - e^{-C_d A}) / (C_d A)`` (A the leaf area met per unit path cross-section), so a dense hedge
slows the spray more than a sparse one and its leaves catch the slowed drops less efficiently.
"""

from __future__ import annotations

import math

import numpy as np

from vinecli.spray.droplets import AIR_DENSITY, AIR_VISCOSITY, WATER_DENSITY

__all__ = ["JET_EDDY_VISCOSITY", "LEAF_DRAG_COEFFICIENT", "ballistic_reach_m", "exit_speed_mps", "footprint_radius_m",
           "mean_speed_through_foliage", "plume_radius_at", "wake_half_width_m", "wake_spread_sigma_m"]

JET_EDDY_VISCOSITY = 0.028  # ν_T / (U_c r_½) of the self-similar round jet, 1/35 (Pope 2000, ch. 5)
LEAF_DRAG_COEFFICIENT = 0.2  # C_d of leaves in canopy-flow models (Katul et al. 2004)
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)


def exit_speed_mps(pressure_bar: float, rho_w: float = WATER_DENSITY) -> float:
    """Liquid speed leaving a hydraulic nozzle at ``pressure_bar`` (Bernoulli, ``sqrt(2 Δp / ρ)``), m/s."""
    return math.sqrt(2.0 * max(pressure_bar, 0.0) * 1e5 / rho_w)


def ballistic_reach_m(d_m: np.ndarray, speed_mps: np.ndarray | float, rho_a: float = AIR_DENSITY,
                      mu: float = AIR_VISCOSITY, rho_w: float = WATER_DENSITY) -> np.ndarray:
    """Distance (m) a drop of diameter ``d_m`` launched at ``speed_mps`` travels before drag stops it (no gravity
    along that direction): ``τ_St ∫_0^V dv / (1 + 0.15 Re^0.687)``, 16-point Gauss–Legendre in v."""
    d = np.asarray(d_m, dtype=np.float64)
    v0 = np.broadcast_to(np.maximum(np.asarray(speed_mps, dtype=np.float64), 0.0), d.shape)
    tau = rho_w * d * d / (18.0 * mu)
    v = 0.5 * v0[..., None] * (_GL_X + 1.0)
    re = (rho_a * d / mu)[..., None] * v
    integral = 0.5 * v0 * np.sum(_GL_W / (1.0 + 0.15 * re ** 0.687), axis=-1)
    return tau * integral


def wake_half_width_m(rotor_radius_m: float, n_rotors: int) -> float:
    """Half width of the vehicle's contracted wake (m): the rotors' total disc area as one disc, halved
    (momentum theory's far wake), ``R √n / √2``."""
    return rotor_radius_m * math.sqrt(max(n_rotors, 1) / 2.0)


def wake_spread_sigma_m(half_width_m: float, carried_m: np.ndarray) -> np.ndarray:
    """σ (m, per axis) of the turbulent spreading of drops the wake carried ``carried_m`` metres:
    ``sqrt(2 · 0.028 · r_½ · s)`` (σ² = 2 ν_T t with ν_T = 0.028 U r_½ and U t = s)."""
    return np.sqrt(2.0 * JET_EDDY_VISCOSITY * half_width_m * np.maximum(np.asarray(carried_m, dtype=np.float64), 0.0))


def footprint_radius_m(reach_m: np.ndarray, sigma_m: np.ndarray) -> np.ndarray:
    """Radius (m) of the uniform disc with the variance of a disc of radius ``reach_m`` spread by ``sigma_m``."""
    return np.sqrt(np.asarray(reach_m) ** 2 + 4.0 * np.asarray(sigma_m) ** 2)


def mean_speed_through_foliage(w_top: np.ndarray, leaf_area: np.ndarray,
                               cd: float = LEAF_DRAG_COEFFICIENT) -> np.ndarray:
    """Mean wake speed (m/s) along a path meeting ``leaf_area`` (∫a ds, m²/m²) when it enters at ``w_top``:
    ``w_top (1 - e^{-C_d A}) / (C_d A)`` (→ w_top for no leaves)."""
    x = cd * np.maximum(np.asarray(leaf_area, dtype=np.float64), 0.0)
    factor = np.where(x > 1e-9, -np.expm1(-x) / np.maximum(x, 1e-300), 1.0)
    return np.asarray(w_top) * factor


def plume_radius_at(reach: np.ndarray, wake_var: np.ndarray, radius: np.ndarray, release_h: np.ndarray,
                    z: float | np.ndarray) -> np.ndarray:
    """Radius (m) of a parcel's plume ``z`` m above the ground (:mod:`vinecli.spray.wake`): its ballistic reach
    plus the wake's spreading accumulated from the release height down to z; ``radius`` at the ground."""
    frac = np.clip((release_h - z) / np.maximum(release_h, 1e-9), 0.0, 1.0)
    return np.where(release_h > 0, np.sqrt(np.minimum(reach, radius) ** 2 + wake_var * frac), radius)
