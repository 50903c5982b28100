"""ISA troposphere as Gazebo's barometer plugin computes it (docs/firmware-protocols.md §2).

``T = 288.15 - 0.0065 h`` K and ``p = 101325 / (288.15 / T)^5.256`` Pa with h in metres
above mean sea level, in the troposphere (h <= 11 km). Above it (a vehicle that climbs for hours) the
ISA's isothermal layer continues it, ``T = 216.65`` K and ``p = p11 exp(-g0 (h - 11 km) / (R T))``, so
every altitude has a real, positive pressure; nothing below 11 km changes.
"""

from __future__ import annotations

import math

T0_K = 288.15
P0_PA = 101325.0
LAPSE_K_PER_M = 0.0065
EXPONENT = 5.256
R_AIR = 287.05  # J/(kg K), dry air
TROPOPAUSE_M = 11_000.0
T11_K = T0_K - LAPSE_K_PER_M * TROPOPAUSE_M  # 216.65 K
P11_PA = P0_PA / (T0_K / T11_K) ** EXPONENT
SCALE_M = R_AIR * T11_K / 9.80665  # scale height of the isothermal layer, m
MIN_PRESSURE_PA = 1e-6

__all__ = ["air_density_at", "altitude_at", "pressure_at", "temperature_at"]


def temperature_at(alt_m: float) -> float:
    """ISA temperature (K) at ``alt_m`` m AMSL."""
    if alt_m > TROPOPAUSE_M:
        return T11_K
    return T0_K - LAPSE_K_PER_M * alt_m


def pressure_at(alt_m: float) -> float:
    """ISA static pressure (Pa) at ``alt_m`` m AMSL (Gazebo barometer formula; isothermal above 11 km)."""
    if alt_m > TROPOPAUSE_M:
        return P11_PA * math.exp(-(alt_m - TROPOPAUSE_M) / SCALE_M)
    return P0_PA / (T0_K / (T0_K - LAPSE_K_PER_M * alt_m)) ** EXPONENT


def altitude_at(pressure_pa: float) -> float:
    """Pressure altitude (m AMSL) for a static pressure (Pa): the inverse of :func:`pressure_at` (a noisy
    reading at or below zero is taken as :data:`MIN_PRESSURE_PA`)."""
    if pressure_pa < P11_PA:
        return TROPOPAUSE_M + SCALE_M * math.log(P11_PA / max(pressure_pa, MIN_PRESSURE_PA))
    return (T0_K - T0_K / (P0_PA / pressure_pa) ** (1.0 / EXPONENT)) / LAPSE_K_PER_M


def air_density_at(alt_m: float) -> float:
    """ISA air density (kg/m³) ``p / (R T)`` at ``alt_m`` m AMSL (1.225 at sea level)."""
    return pressure_at(alt_m) / (R_AIR * temperature_at(alt_m))
