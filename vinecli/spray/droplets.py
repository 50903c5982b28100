"""Water droplets in air: terminal velocity, relaxation time, size classes. SI units.

Terminal velocity from the force balance ``(ρ_w - ρ_a) g π d³/6 = ½ ρ_a v² C_D π d²/4`` with the
Schiller–Naumann drag law ``C_D = 24/Re (1 + 0.15 Re^0.687)`` (Schiller & Naumann 1933; Clift,
Grace & Weber 1978, valid Re < ~800, i.e. water drops up to ~2 mm in air), solved by Newton
iteration on ``v``. It reduces to Stokes' law ``v = (ρ_w - ρ_a) g d² / (18 μ)`` for Re -> 0.
Checked against Gunn & Kinzer (1949) in tests/spray/test_droplets.py.

Size classes: the volume distribution of drop diameters is log-normal with median ``vmd``
(Dv0.5) and geometric standard deviation ``gsd``; ``n`` classes of equal volume, each
represented by the diameter at the middle volume quantile of its class.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

from vinecli.constants import STANDARD_GRAVITY

__all__ = ["AIR_DENSITY", "AIR_VISCOSITY", "WATER_DENSITY", "relaxation_time_s", "size_classes_m",
           "stokes_velocity", "terminal_velocity"]

WATER_DENSITY = 998.2  # kg/m³, 20 °C
AIR_DENSITY = 1.204  # kg/m³, 20 °C, 1013.25 hPa
AIR_VISCOSITY = 1.81e-5  # Pa s, 20 °C
G = STANDARD_GRAVITY


def stokes_velocity(d_m: float | np.ndarray, rho_w: float = WATER_DENSITY, rho_a: float = AIR_DENSITY,
                    mu: float = AIR_VISCOSITY, g: float = G) -> float | np.ndarray:
    """Stokes terminal velocity (Re << 1) of a sphere of diameter ``d_m`` (m), m/s."""
    return (rho_w - rho_a) * g * np.asarray(d_m) ** 2 / (18.0 * mu)


def terminal_velocity(d_m: float | np.ndarray, rho_w: float = WATER_DENSITY, rho_a: float = AIR_DENSITY,
                      mu: float = AIR_VISCOSITY, g: float = G) -> np.ndarray:
    """Terminal fall speed (m/s, positive down) of water drops of diameter ``d_m`` (m), Schiller–Naumann drag.

    Solves ``f(v) = 3 ρ_a C_D(Re) v² - 4 g d (ρ_w - ρ_a) = 0`` with ``C_D Re = 24 (1 + 0.15 Re^0.687)``,
    i.e. ``18 μ v (1 + 0.15 Re^0.687) = (ρ_w - ρ_a) g d²``, by Newton from the Stokes value.
    """
    d = np.atleast_1d(np.asarray(d_m, dtype=np.float64))
    if np.any(d <= 0):
        raise ValueError("droplet diameters must be > 0")
    rhs = (rho_w - rho_a) * g * d * d / (18.0 * mu)  # = v (1 + 0.15 Re^0.687)
    k = rho_a * d / mu  # Re = k v
    v = np.minimum(rhs, 10.0)
    for _ in range(50):
        re = k * v
        f = v * (1.0 + 0.15 * re ** 0.687) - rhs
        df = 1.0 + 0.15 * 1.687 * re ** 0.687
        step = f / df
        v = np.maximum(v - step, 1e-9)
        if np.all(np.abs(step) <= 1e-12 * np.maximum(v, 1e-6)):
            break
    return v


def relaxation_time_s(v_terminal: np.ndarray, g: float = G) -> np.ndarray:
    """Momentum relaxation time at terminal velocity, s: τ = v_t / g (drag balances weight).

    Equals the Stokes ``ρ_w d² / (18 μ)`` for small drops and includes the nonlinear drag for larger ones.
    """
    return np.asarray(v_terminal, dtype=np.float64) / g


def size_classes_m(vmd_um: float, gsd: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(diameters m, volume fractions) of ``n`` equal-volume classes of a log-normal volume distribution."""
    if n < 1:
        raise ValueError("need at least one size class")
    nd = NormalDist()
    s = math.log(gsd) if gsd > 1.0 else 0.0
    q = [(i + 0.5) / n for i in range(n)]
    d = np.array([vmd_um * 1e-6 * math.exp(s * nd.inv_cdf(p)) for p in q])
    return d, np.full(n, 1.0 / n)
