"""ISA troposphere as Gazebo's barometer plugin computes it (px4-sitl-and-mavlink.md §1.7).

``T = 288.15 - 0.0065 h`` K and ``p = 101325 / (288.15 / T)^5.256`` Pa with h in metres
above mean sea level (valid in the troposphere, h < 11 km).
"""

from __future__ import annotations

T0_K = 288.15
P0_PA = 101325.0
LAPSE_K_PER_M = 0.0065
EXPONENT = 5.256
R_AIR = 287.05  # J/(kg K), dry air

__all__ = ["air_density_at", "altitude_at", "pressure_at", "temperature_at"]


def temperature_at(alt_m: float) -> float:
    """ISA temperature (K) at ``alt_m`` m AMSL."""
    return T0_K - LAPSE_K_PER_M * alt_m


def pressure_at(alt_m: float) -> float:
    """ISA static pressure (Pa) at ``alt_m`` m AMSL (Gazebo barometer formula)."""
    return P0_PA / (T0_K / (T0_K - LAPSE_K_PER_M * alt_m)) ** EXPONENT


def altitude_at(pressure_pa: float) -> float:
    """Pressure altitude (m AMSL) for a static pressure (Pa): the inverse of :func:`pressure_at`."""
    return (T0_K - T0_K / (P0_PA / pressure_pa) ** (1.0 / EXPONENT)) / LAPSE_K_PER_M


def air_density_at(alt_m: float) -> float:
    """ISA air density (kg/m³) ``p / (R T)`` at ``alt_m`` m AMSL (1.225 at sea level)."""
    return pressure_at(alt_m) / (R_AIR * temperature_at(alt_m))
