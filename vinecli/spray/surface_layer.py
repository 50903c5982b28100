"""Far-field drift: fine drops carried through the atmospheric surface layer until they settle. SI units, metres.

The drops the rotor wake does not drive into the ground (:mod:`vinecli.spray.outwash`) leave the wall jet
and are carried downwind by the mean wind while the surface layer's turbulence moves them up and down and
gravity settles them at their terminal velocity ``v_t``.

* **Mean wind**: Monin–Obukhov similarity, ``U(z) = u*/κ [ln(z/z0) - ψ_m(z/L) + ψ_m(z0/L)]`` with the
  Businger–Dyer forms (Businger et al. 1971; Dyer 1974; Paulson 1970's ψ_m for unstable air), κ = 0.41,
  the crop's roughness ``z0``; ``u*`` from the wind at the vehicle's height. ``L`` = ∞ is the neutral
  default; L > 0 stable, L < 0 unstable.
* **Turbulence**: ``σ_w = 1.25 u*`` (neutral and stable), ``1.25 u* (1 - 3 z/L)^{1/3}`` unstable (Panofsky &
  Dutton 1984; Kaimal & Finnigan 1994); eddy diffusivity ``K = κ u* z / φ_h(z/L)``; Lagrangian time scale
  ``T_L = K / σ_w²`` (so the model's far-field diffusivity is the surface layer's K).
* **Drops**: a 1-D vertical Lagrangian stochastic model (Langevin equation well mixed in Gaussian
  inhomogeneous turbulence, Thomson 1987, J. Fluid Mech. 180:529; Wilson & Sawford 1996, Boundary-Layer
  Meteorol. 78:191): ``dw = -w dt / T_p + ½ (1 + w²/σ_w²) ∂σ_w²/∂z dt + sqrt(2 σ_w² / T_p) dξ``, the drop moving
  at ``w - v_t`` vertically and ``U(z)`` downwind. Heavy drops fall through eddies and lose their velocity
  memory faster: ``T_p = T_L / sqrt(1 + (v_t/σ_w)²)`` (crossing trajectories, Csanady 1963, J. Atmos. Sci.
  20:201). A drop that reaches ``z0`` deposits (the ground and low vegetation are a sink).
* **Deterministic**: one fixed-seed ensemble per (drop class, u*, release layer, stability) — a Monte-Carlo
  quadrature of the Langevin model, the same in every run — cached per process.

Left out: along-wind turbulence (small beside the advection), the hedges' own wind profile (the crop is
a roughness, not a porous layer, for the far field), evaporation shrinking the drops in flight (the budget
takes the volume off, the fall speed stays), and thermal plumes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

__all__ = ["KARMAN", "SIGMA_W_USTAR", "SurfaceLayer", "landing_bands"]

KARMAN = 0.41
SIGMA_W_USTAR = 1.25  # σ_w / u*, neutral surface layer (Panofsky & Dutton 1984)
ENSEMBLE = 768  # drops per ensemble
MAX_STEPS = 6000
#: the landing density's bins: from X_MIN_M to the model's reach, evenly in log-distance; each drop's landing
#: point spread over ±KERNEL_LOG in ln x (a kernel density estimate: the ensemble's sampling noise smoothed)
X_MIN_M = 0.05
LOG_BINS = 64
KERNEL_LOG = 0.2
#: bins holding less than this share of the landed drops are merged into the heaviest (no parcel for a kernel tail)
NEGLIGIBLE = 1e-5


@dataclass(frozen=True)
class SurfaceLayer:
    """The surface layer: friction velocity u* (m/s), roughness z0 (m), Obukhov length L (m, inf = neutral)."""

    ustar: float
    z0: float
    obukhov_m: float = math.inf

    @classmethod
    def from_wind(cls, speed_mps: float, z_ref_m: float, z0: float, obukhov_m: float = math.inf) -> SurfaceLayer:
        """The layer whose wind at ``z_ref_m`` is ``speed_mps``."""
        zr = max(z_ref_m, 2.0 * z0)
        shape = math.log(zr / z0) - _psi_m(zr / obukhov_m) + _psi_m(z0 / obukhov_m)
        return cls(KARMAN * max(speed_mps, 0.0) / max(shape, 1e-6), z0, obukhov_m)

    def wind(self, z: np.ndarray) -> np.ndarray:
        """Mean wind speed (m/s) at heights z (m)."""
        z = np.maximum(np.asarray(z, dtype=np.float64), self.z0)
        return self.ustar / KARMAN * (np.log(z / self.z0) - _psi_m(z / self.obukhov_m) + _psi_m(self.z0 / self.obukhov_m))

    def sigma_w(self, z: np.ndarray) -> np.ndarray:
        """Standard deviation of the vertical velocity (m/s)."""
        z = np.asarray(z, dtype=np.float64)
        if self.obukhov_m < 0:
            return SIGMA_W_USTAR * self.ustar * np.cbrt(1.0 - 3.0 * z / self.obukhov_m)
        return np.full(z.shape, SIGMA_W_USTAR * self.ustar)

    def diffusivity(self, z: np.ndarray) -> np.ndarray:
        """Eddy diffusivity of scalars, ``κ u* z / φ_h`` (m²/s)."""
        z = np.maximum(np.asarray(z, dtype=np.float64), self.z0)
        return KARMAN * self.ustar * z / _phi_h(z / self.obukhov_m)


def _psi_m(zeta: np.ndarray | float) -> np.ndarray:
    """Integrated stability function of momentum (Businger–Dyer; Paulson 1970 for ζ < 0)."""
    zeta = np.asarray(zeta, dtype=np.float64)
    if not (zeta < 0).any():  # neutral or stable air (the default L = inf): the unstable form is not needed
        return np.asarray(-5.0 * zeta)
    x = np.power(np.maximum(1.0 - 16.0 * np.minimum(zeta, 0.0), 1.0), 0.25)
    unstable = 2.0 * np.log((1.0 + x) / 2.0) + np.log((1.0 + x * x) / 2.0) - 2.0 * np.arctan(x) + math.pi / 2.0
    return np.where(zeta < 0, unstable, -5.0 * zeta)


def _phi_h(zeta: np.ndarray) -> np.ndarray:
    """Dimensionless gradient of scalars (Businger–Dyer): 1 + 5ζ stable, (1 - 16ζ)^-1/2 unstable."""
    if not (zeta < 0).any():  # neutral or stable air: the unstable form is not needed
        return 1.0 + 5.0 * np.maximum(zeta, 0.0)
    return np.where(zeta < 0, 1.0 / np.sqrt(np.maximum(1.0 - 16.0 * zeta, 1.0)), 1.0 + 5.0 * np.maximum(zeta, 0.0))


def landing_bands(layer: SurfaceLayer, v_t: tuple[float, float], release_top_m: float, x_max_m: float,
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where drops with terminal velocities spread evenly in log between ``v_t`` = (lowest, highest) m/s (a size
    class: one speed would give each class its own landing peak and the curve steps from class to class),
    released evenly between the ground and ``release_top_m``, land.

    Returns (mass, distance m, half width m, time s) of the bins of the landing density (a kernel estimate in
    log-distance, :data:`KERNEL_LOG`, :data:`LOG_BINS` bins) of the drops that land within ``x_max_m``
    downwind, and a last entry for those still airborne there (distance inf).
    Rounded inputs key a per-process cache (u* to 1 %, v_t to 1 %, heights to 1 cm).
    """
    return _bands(round(layer.ustar, 4 if layer.ustar < 0.1 else 3), layer.z0, layer.obukhov_m,
                  float(f"{v_t[0]:.3g}"), float(f"{v_t[1]:.3g}"), round(release_top_m, 2), round(x_max_m))


@lru_cache(maxsize=4096)  # a gusty or turbulent run asks for thousands (3,212 in the golden laws run), ~2 kB each
def _bands(ustar: float, z0: float, obukhov_m: float, vt_lo: float, vt_hi: float, top: float,
           x_max: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    x, t, landed = _ensemble(SurfaceLayer(ustar, z0, obukhov_m), (vt_lo, vt_hi), top, x_max)
    out_share = 1.0 - landed.sum() / x.size
    xs, ts = x[landed], t[landed]
    # the landing density: a kernel estimate in log-distance (each drop spread over ±KERNEL_LOG in ln x), binned
    lx = np.log(np.maximum(xs, X_MIN_M))
    edges = np.linspace(math.log(X_MIN_M), math.log(max(x_max, 2 * X_MIN_M)), LOG_BINS + 1)
    cdf = _norm_cdf((edges[None, :] - lx[:, None]) / KERNEL_LOG)
    share = np.diff(cdf, axis=1)
    share /= np.maximum(share.sum(axis=1, keepdims=True), 1e-300)  # every landed drop keeps its mass
    mass = share.sum(axis=0) / x.size
    lo, hi = np.exp(edges[:-1]), np.exp(edges[1:])
    lo[0] = 0.0
    mid = 0.5 * (lo + hi)
    weight = share.sum(axis=0)
    time = np.where(weight > 0, (share * ts[:, None]).sum(axis=0) / np.maximum(weight, 1e-300), 0.0)  # flight time
    keep = mass > NEGLIGIBLE * mass.sum()  # the kernel's far tails: their mass goes to the heaviest bin
    if mass.size:
        mass[int(np.argmax(mass))] += float(mass[~keep].sum())
    tail = float(x_max / max(float(layer_wind_mean(ustar, z0, obukhov_m, top)), 1e-3))
    return (np.append(mass[keep], out_share), np.append(mid[keep], math.inf),
            np.append(0.5 * (hi - lo)[keep], 0.0), np.append(time[keep], tail))


def _norm_cdf(z: np.ndarray) -> np.ndarray:
    """Standard normal CDF."""
    from scipy.special import ndtr

    return np.asarray(ndtr(z))


def layer_wind_mean(ustar: float, z0: float, obukhov_m: float, top: float) -> float:
    """Mean wind over the release layer (m/s), for the travel time of the drops still airborne at the edge."""
    z = np.linspace(max(z0, 0.05 * top), max(top, 2 * z0), 9)
    return float(SurfaceLayer(ustar, z0, obukhov_m).wind(z).mean())


def _ensemble(layer: SurfaceLayer, vt_range: tuple[float, float], top: float, x_max: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Landing distance (m), time (s) and whether each of :data:`ENSEMBLE` drops landed within ``x_max``."""
    n = ENSEMBLE
    rng = np.random.default_rng(np.random.SeedSequence(20241, spawn_key=(0x5A1,)))
    z_floor = layer.z0
    z = z_floor + (top - z_floor) * (np.arange(n) + 0.5) / n  # released evenly over the layer
    lo, hi = max(min(vt_range), 1e-6), max(vt_range)
    v_t = lo * (hi / lo) ** rng.permutation((np.arange(n) + 0.5) / n)  # the class's speeds, evenly in log
    x = np.zeros(n)
    t = np.zeros(n)
    if layer.ustar < 1e-3 or top <= z_floor:  # no turbulence: each drop settles straight down
        fall = np.maximum(z - z_floor, 0.0) / v_t
        xx = layer.wind(0.5 * (z + z_floor)) * fall
        return xx, fall, xx <= x_max
    sw = layer.sigma_w(z)
    w = sw * rng.standard_normal(n)
    # the airborne drops' state, kept compacted in index order (the arithmetic and the random draws of gathering
    # them from the whole ensemble every step, without the gathers); a drop that lands or leaves is written back
    idx, zi, wi, vt, xi, ti = np.arange(n), z, w, v_t, x, t
    for _ in range(MAX_STEPS):
        if idx.size == 0:
            break
        sw = layer.sigma_w(zi)
        tl = layer.diffusivity(zi) / (sw * sw)
        tp = tl / np.sqrt(1.0 + (vt / sw) ** 2)
        dt = np.maximum(np.minimum(0.1 * tp, 0.2 * (zi - z_floor + 0.02) / (np.abs(wi) + vt + 1e-3)), 1e-3)
        dsw2 = _dsigma2_dz(layer, zi)
        wi = wi + (-wi / tp + 0.5 * (1.0 + wi * wi / (sw * sw)) * dsw2) * dt + np.sqrt(2.0 * sw * sw / tp * dt) * (
            rng.standard_normal(idx.size))
        xi = xi + layer.wind(zi) * dt
        zi = zi + (wi - vt) * dt
        ti = ti + dt
        done = (zi <= z_floor) | (xi > x_max)
        if done.any():
            x[idx[done]], t[idx[done]] = xi[done], ti[done]
            keep = ~done
            idx, zi, wi, vt, xi, ti = idx[keep], zi[keep], wi[keep], vt[keep], xi[keep], ti[keep]
    x[idx], t[idx] = xi, ti
    # drops still airborne after MAX_STEPS (a few, within centimetres of the ground) land where they are
    return x, t, x <= x_max


def _dsigma2_dz(layer: SurfaceLayer, z: np.ndarray) -> np.ndarray:
    """∂σ_w²/∂z (m/s²): 0 in neutral and stable air."""
    if layer.obukhov_m >= 0:
        return np.zeros_like(z)
    u = SIGMA_W_USTAR * layer.ustar
    return u * u * (2.0 / 3.0) * (-3.0 / layer.obukhov_m) * np.cbrt(1.0 - 3.0 * z / layer.obukhov_m) ** -1
