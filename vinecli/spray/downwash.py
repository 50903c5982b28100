"""Rotor downwash from momentum theory, and the fall time of a drop through it. SI, world ENU.

* Induced velocity at the disc (Glauert's momentum theory, level flight at airspeed ``V``):
  ``v_i⁴ + V² v_i² = v_h⁴`` with the hover value ``v_h = sqrt(T / (2 ρ A))``, i.e.
  ``v_i² = (sqrt(V⁴ + 4 v_h⁴) - V²) / 2`` (Leishman, Principles of Helicopter Aerodynamics,
  2nd ed., §2.14 / eq. 2.248 for α = 0). Forward flight and crosswind weaken the downwash.
* Axial wake velocity at a depth ζ below the rotor plane (actuator disc + vortex cylinder,
  Leishman §3.2): ``w₀(ζ) = v_i (1 + ζ / sqrt(ζ² + R²))``, which reaches the fully developed
  ``2 v_i`` about one radius below the disc.
* Decay: beyond a core length ``L_c = core_radii · R`` the wake mixes like a round turbulent jet
  whose centreline velocity falls as 1/distance (Pope, Turbulent Flows, 2000, §5.1):
  ``w(ζ) = w₀(ζ) · min(1, L_c / ζ)``. ``core_radii`` = 4 (two rotor diameters) is an assumption
  of this model (docs/deposition.md).

A drop of terminal speed ``v_t`` in a vertical air speed ``w_z`` (wind, up positive) falls at
``v_t + w(ζ) - w_z``; the fall time over a height h is ``∫ dζ / (v_t + w(ζ) - w_z)``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["CORE_RADII", "MIN_FALL_FRACTION", "fall_time_s", "hover_induced_velocity", "induced_velocity",
           "crossflow_bending", "wake_velocity"]

CORE_RADII = 4.0
#: an updraft stronger than the fall speed would loft the drop: the fall speed is kept at least this share of v_t
MIN_FALL_FRACTION = 0.1
_N_FALL = 16  # midpoint steps of the fall-time integral (tests: < 0.5 % from 400 steps)


def hover_induced_velocity(thrust_n: np.ndarray | float, rho: float, radius_m: float) -> np.ndarray:
    """Momentum-theory hover induced velocity ``sqrt(T / (2 ρ π R²))`` (m/s) for a rotor thrust T (N)."""
    t = np.maximum(np.asarray(thrust_n, dtype=np.float64), 0.0)
    return np.sqrt(t / (2.0 * rho * math.pi * radius_m * radius_m))


def induced_velocity(thrust_n: np.ndarray | float, rho: float, radius_m: float,
                     airspeed_mps: np.ndarray | float = 0.0) -> np.ndarray:
    """Induced velocity at the disc (m/s) in level flight at horizontal ``airspeed_mps`` (Glauert)."""
    vh = hover_induced_velocity(thrust_n, rho, radius_m)
    v2 = np.asarray(airspeed_mps, dtype=np.float64) ** 2
    return np.sqrt(0.5 * (np.sqrt(v2 * v2 + 4.0 * vh ** 4) - v2))


def crossflow_bending(thrust_n: np.ndarray | float, rho: float, airspeed_mps: np.ndarray | float) -> np.ndarray:
    """``1 / l_m`` (1/m) of the wake in a crossflow: ``U / sqrt(T/ρ)`` for the total thrust T (0 in still air)."""
    u = np.abs(np.asarray(airspeed_mps, dtype=np.float64))
    m = np.sqrt(np.maximum(np.asarray(thrust_n, dtype=np.float64), 0.0) / rho)
    return np.where(m > 1e-9, u / np.maximum(m, 1e-9), 0.0)


def wake_velocity(zeta_m: np.ndarray, v_i: np.ndarray, radius_m: float, core_radii: float = CORE_RADII,
                  bending: np.ndarray | float = 0.0) -> np.ndarray:
    """Downward wake speed (m/s) at a depth ``zeta_m`` (m, ≥ 0) below the rotor plane; ``bending`` = 1/l_m (1/m) of
    the crossflow bends it over (:func:`crossflow_bending`; 0: still air)."""
    z = np.maximum(np.asarray(zeta_m, dtype=np.float64), 0.0)
    w0 = v_i * (1.0 + z / np.sqrt(z * z + radius_m * radius_m))
    lc = core_radii * radius_m
    return w0 * np.minimum(1.0, lc / np.maximum(z, 1e-9)) / (1.0 + z * np.asarray(bending, dtype=np.float64))


def fall_time_s(height_m: np.ndarray, zeta0_m: np.ndarray, v_t: np.ndarray, v_i: np.ndarray, w_up: np.ndarray,
                radius_m: float, core_radii: float = CORE_RADII, bending: np.ndarray | float = 0.0,
                ) -> tuple[np.ndarray, np.ndarray]:
    """Fall time (s) over ``height_m`` from a depth ``zeta0_m`` below the rotors, and the fall speed at the ground.

    Arrays broadcast together; ``v_i = 0`` gives the still-air fall ``h / v_t`` (with ``w_up`` = 0).
    Midpoint rule over 16 steps in ζ (the wake speed is smooth in ζ).
    """
    h = np.maximum(np.asarray(height_m, dtype=np.float64), 0.0)
    zeta0 = np.asarray(zeta0_m, dtype=np.float64)
    vt = np.asarray(v_t, dtype=np.float64)
    floor = MIN_FALL_FRACTION * vt
    dz = h / _N_FALL
    t = np.zeros(np.broadcast(h, zeta0, vt, v_i, w_up).shape)
    for k in range(_N_FALL):
        z = zeta0 + (k + 0.5) * dz
        s = np.maximum(vt + wake_velocity(z, v_i, radius_m, core_radii, bending) - w_up, floor)
        t = t + dz / s
    s_end = np.maximum(vt + wake_velocity(zeta0 + h, v_i, radius_m, core_radii, bending) - w_up, floor)
    return t, s_end
