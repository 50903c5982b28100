"""Fine drops the rotor wake does not drive into the ground: lifted by the outwash, then carried by the wind.

The vehicle's downwash reaches the ground as a jet of diameter ``W`` (the rotors' merged wake,
``W = D_prop √n_rotors``) at the speed ``U`` the fall model has there. Like particles in an inertial
impactor, drops with enough inertia cross the jet's turn and hit the ground; the others follow the
air into the radial outwash. The share that impacts is the round-jet impactor efficiency against
``Stk = ρ_w d² U / (9 μ W)``, 50 % at ``√Stk50 = 0.49`` (Marple & Willeke 1976, in *Fine Particles*,
Liu ed., Academic Press; Hinds, *Aerosol Technology*, 2nd ed., §5.5). The shape around the cut is this
model's assumption: a logistic in ``√Stk`` going from 10 % to 90 % over ±0.1 (a sharp impactor).

The drops that follow the outwash are released again at ``h_s = W/2`` above the ground (the
recirculating ground vortex of a rotor near the ground, about a wake radius high), ``W/2`` downwind of
their landing point, and fall at their terminal velocity ``v_t`` while the turbulence of the surface
layer spreads them: with a constant eddy diffusivity ``K`` the time to reach the ground is the
first-passage time of a Brownian motion with drift ``v_t`` from ``h_s``, inverse Gaussian with mean
``μ = h_s / v_t`` and shape ``λ = h_s² / (2K)`` (Chhikara & Folks 1989). The wind carries them
``u t``: each lifted parcel becomes :data:`NODE_MASSES` parcels at the conditional medians of that
distribution's probability bands, so the drift curve keeps its tail (the last band holds the top 1 %).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["NODE_MASSES", "NODE_PROBS", "SQRT_STK50", "impaction_share", "inverse_gaussian_cdf", "inverse_gaussian_quantiles",
           "lifted_parcels"]

SQRT_STK50 = 0.49  # Marple & Willeke 1976, round jets
_WIDTH = 0.1 / np.log(9.0)  # logistic scale: 10 % -> 90 % over ±0.1 in √Stk
#: probability bands the lifted volume is split into (sum 1), smallest last: the far tail
NODE_MASSES = np.array([0.25, 0.25, 0.2, 0.15, 0.1, 0.04, 0.01])
_EDGES = np.concatenate([[0.0], np.cumsum(NODE_MASSES)])
#: each band's probability midpoint: its parcel lands at that quantile of the landing time
NODE_PROBS = 0.5 * (_EDGES[:-1] + _EDGES[1:])


def impaction_share(d_m: np.ndarray, jet_speed_mps: np.ndarray, jet_diam_m: float, rho_w: float = 998.2,
                    mu: float = 1.81e-5) -> np.ndarray:
    """Share of the drops (diameter m) the wake (speed m/s, diameter m) drives into the ground, 0..1."""
    stk = rho_w * np.asarray(d_m) ** 2 * np.maximum(np.asarray(jet_speed_mps, dtype=np.float64), 0.0) / (
        9.0 * mu * jet_diam_m)
    return 1.0 / (1.0 + np.exp(-(np.sqrt(stk) - SQRT_STK50) / _WIDTH))


def _erfcx(z: np.ndarray) -> np.ndarray:
    """exp(z²) erfc(z) for z >= 0: the Chebyshev fit of Numerical Recipes (Press et al. 2007, §6.2.2,
    ``erfcc``; relative error < 1.2e-7 everywhere), which is erfcx times exp(-z²) by construction."""
    t = 1.0 / (1.0 + 0.5 * z)
    poly = (-1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418 + t * (-0.18628806 + t * (
        0.27886807 + t * (-1.13520398 + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277)))))))))
    return t * np.exp(poly)


def _erfc(z: np.ndarray) -> np.ndarray:
    a = np.abs(z)
    e = _erfcx(a) * np.exp(-a * a)
    return np.where(z >= 0, e, 2.0 - e)


def inverse_gaussian_cdf(t: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """CDF at ``t`` > 0 of the unit-mean inverse Gaussian IG(1, φ) (IG(μ, λ) is μ · IG(1, λ/μ)); stable for large φ."""
    t = np.maximum(np.asarray(t, dtype=np.float64), 1e-300)
    r = np.sqrt(phi / t)
    a = r * (t - 1.0)
    b = r * (t + 1.0)
    # exp(2φ) Φ(-b) = ½ exp(2φ - b²/2) erfcx(b/√2), and 2φ - b²/2 = -φ (t - 1)² / (2t)
    return 0.5 * _erfc(-a / math.sqrt(2.0)) + 0.5 * np.exp(-phi * (t - 1.0) ** 2 / (2.0 * t)) * _erfcx(
        b / math.sqrt(2.0))


_LOG_PHI = np.linspace(math.log(1e-4), math.log(1e6), 241)
_TABLE: np.ndarray | None = None


def _quantile_table() -> np.ndarray:
    """(len(_LOG_PHI), len(NODE_PROBS)) log-quantiles of IG(1, φ), by bisection in log t (built once, ~10 ms)."""
    global _TABLE
    if _TABLE is None:
        phi = np.exp(_LOG_PHI)[:, None]
        p = NODE_PROBS[None, :]
        lo = np.full((phi.size, p.size), -30.0)
        hi = np.full((phi.size, p.size), 30.0)
        for _ in range(64):
            mid = 0.5 * (lo + hi)
            below = inverse_gaussian_cdf(np.exp(mid), phi) < p
            lo = np.where(below, mid, lo)
            hi = np.where(below, hi, mid)
        _TABLE = 0.5 * (lo + hi)
    return _TABLE


def inverse_gaussian_quantiles(mu: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """(n, len(NODE_PROBS)) quantiles of IG(μ_i, λ_i) at :data:`NODE_PROBS` (log-φ interpolation of a table)."""
    mu = np.asarray(mu, dtype=np.float64)
    lphi = np.clip(np.log(np.asarray(lam, dtype=np.float64) / mu), _LOG_PHI[0], _LOG_PHI[-1])
    tab = _quantile_table()
    f = (lphi - _LOG_PHI[0]) / (_LOG_PHI[1] - _LOG_PHI[0])
    i = np.minimum(f.astype(np.int64), _LOG_PHI.size - 2)
    w = (f - i)[:, None]
    return mu[:, None] * np.exp(tab[i] * (1.0 - w) + tab[i + 1] * w)


# parameters: the formula's inputs (module doc): arrays of the lifted parcels, one value per parcel each
def lifted_parcels(x: np.ndarray, y: np.ndarray, lifted_l: np.ndarray, v_t: np.ndarray, t_fall: np.ndarray,
                   wind_x: np.ndarray, wind_y: np.ndarray, kdiff: np.ndarray, jet_diam_m: float,
                   ) -> dict[str, np.ndarray]:
    """The parcels the outwash re-releases (see the module doc), one per lifted parcel and probability band.

    Inputs per lifted parcel: landing point (m ENU), lifted volume (L), terminal velocity (m/s), fall
    time so far (s), wind at the release height (m/s ENU), eddy diffusivity there (m²/s). Returns
    ``x, y, vol, t_fall, vx, vy, vz, src`` (src: index of the parcel it came from).
    """
    n = x.size
    h_s = 0.5 * jet_diam_m
    speed = np.hypot(wind_x, wind_y)
    ex = np.where(speed > 0, wind_x / np.maximum(speed, 1e-12), 0.0)
    ey = np.where(speed > 0, wind_y / np.maximum(speed, 1e-12), 0.0)
    mu = h_s / np.maximum(v_t, 1e-6)
    lam = h_s * h_s / (2.0 * np.maximum(kdiff, 1e-9))
    t = inverse_gaussian_quantiles(mu, lam)  # (n, m)
    m = NODE_PROBS.size
    travel = wind_x[:, None] * t, wind_y[:, None] * t
    out = {
        "x": (x[:, None] + ex[:, None] * h_s + travel[0]).ravel(),
        "y": (y[:, None] + ey[:, None] * h_s + travel[1]).ravel(),
        "vol": (lifted_l[:, None] * NODE_MASSES[None, :]).ravel(),
        "t_fall": (t_fall[:, None] + t).ravel(),
        "vx": np.repeat(wind_x, m), "vy": np.repeat(wind_y, m), "vz": np.repeat(v_t, m),
        "src": np.repeat(np.arange(n), m),
    }
    return out
