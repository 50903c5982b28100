"""Evaporation of water drops in flight: the d² law. SI units (temperatures in °C where named so).

A drop evaporates at a rate set by vapour diffusion from its surface, which sits at the wet-bulb
temperature: ``dm/dt = -2π d D_v (ρ_v,s(T_wb) - ρ_v,∞) f`` (Maxwell), i.e. with ``m = ρ_w π d³/6``

    d(d²)/dt = -λ,   λ = 8 D_v Δρ_v f / ρ_w,

so ``d² = d0² - λ t`` and the volume left after a time t is ``(1 - λ t / d0²)^{3/2}`` (0 once the drop
is gone, after ``d0² / λ``). ``f = 1 + 0.276 Re^{1/2} Sc^{1/3}`` is Frössling's (1938) ventilation
factor of a drop falling at its terminal velocity (Re at the initial diameter).

* wet-bulb temperature: Stull 2011, J. Appl. Meteor. Climatol. 50:2267 (RH 5-99 %, -20..50 °C);
* saturation vapour pressure over water: Bolton 1980, Mon. Wea. Rev. 108:1046;
* vapour diffusivity in air: ``2.11e-5 (T/273.15)^1.94`` m²/s at 1013 hPa (Pruppacher & Klett 1997, eq. 13.3).

The rule of thumb of spray practice, a drop's lifetime ``d²/(80 ΔT)`` s with d in µm and the
wet-bulb depression ΔT in K (Amsden 1962; Matthews, *Pesticide Application Methods*), is the same
law with λ ≈ 80 ΔT µm²/s; tests/spray/test_budget_models.py compares the two.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["evaporation_constant", "remaining_fraction", "saturation_vapour_pressure_pa", "vapour_diffusivity",
           "wet_bulb_c"]

R_VAPOUR = 461.5  # J/(kg K), water vapour
SCHMIDT_AIR_VAPOUR = 0.6  # ν/D_v of water vapour in air near 20 °C


def saturation_vapour_pressure_pa(t_c: float | np.ndarray) -> np.ndarray:
    """Saturation vapour pressure over liquid water, Pa (Bolton 1980), temperature in °C."""
    t = np.asarray(t_c, dtype=np.float64)
    return 611.2 * np.exp(17.67 * t / (t + 243.5))


def wet_bulb_c(t_c: float, rh_pct: float) -> float:
    """Wet-bulb temperature (°C) of air at ``t_c`` °C and ``rh_pct`` % relative humidity (Stull 2011)."""
    rh = min(max(float(rh_pct), 0.0), 100.0)
    t = float(t_c)
    tw = (t * math.atan(0.151977 * math.sqrt(rh + 8.313659)) + math.atan(t + rh) - math.atan(rh - 1.676331)
          + 0.00391838 * rh ** 1.5 * math.atan(0.023101 * rh) - 4.686035)
    return min(tw, t)


def vapour_diffusivity(t_c: float) -> float:
    """Diffusivity of water vapour in air at 1013 hPa, m²/s (Pruppacher & Klett 1997)."""
    return 2.11e-5 * ((t_c + 273.15) / 273.15) ** 1.94


def evaporation_constant(d_m: np.ndarray, v_t: np.ndarray, t_c: float, rh_pct: float, rho_w: float = 998.2,
                         nu_air: float = 1.5e-5, ventilation: bool = True) -> np.ndarray:
    """λ = -d(d²)/dt (m²/s) of drops of diameter ``d_m`` falling at ``v_t`` (m/s) in air at ``t_c`` °C, ``rh_pct`` %."""
    tw = wet_bulb_c(t_c, rh_pct)
    rho_s = float(saturation_vapour_pressure_pa(tw)) / (R_VAPOUR * (tw + 273.15))
    rho_inf = 0.01 * rh_pct * float(saturation_vapour_pressure_pa(t_c)) / (R_VAPOUR * (t_c + 273.15))
    d_rho = max(rho_s - rho_inf, 0.0)
    d = np.asarray(d_m, dtype=np.float64)
    f = np.ones_like(d)
    if ventilation:
        re = np.asarray(v_t, dtype=np.float64) * d / nu_air
        f = 1.0 + 0.276 * np.sqrt(re) * SCHMIDT_AIR_VAPOUR ** (1.0 / 3.0)
    return 8.0 * vapour_diffusivity(t_c) * d_rho * f / rho_w


def remaining_fraction(d0_m: np.ndarray, lam_m2ps: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """Volume fraction of a drop (initial diameter ``d0_m``) left after ``t_s`` seconds of the d² law, 0..1."""
    x = 1.0 - np.asarray(lam_m2ps, dtype=np.float64) * np.asarray(t_s, dtype=np.float64) / np.asarray(d0_m) ** 2
    return np.maximum(x, 0.0) ** 1.5
