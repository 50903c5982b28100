"""Quadratic wind drag on a link (thesis §2.2.2 "wind-drag" plugin, design.md §3).

``F = c |V_app|² V_app/|V_app| = c |V_app| V_app`` with ``V_app = wind - v_link`` and
``c = ½ ρ S C_D0`` (kg/m). Any frame works as long as both vectors share it (the simulation
uses world ENU). With zero wind a climbing drone therefore feels drag pointing down.
"""

from __future__ import annotations

import math

from vinecli.frames import Vec3

__all__ = ["apparent_velocity", "wind_drag"]


def apparent_velocity(wind: Vec3, v_link: Vec3) -> Vec3:
    """``wind - v_link`` (m/s, same frame as the inputs)."""
    return (wind[0] - v_link[0], wind[1] - v_link[1], wind[2] - v_link[2])


def wind_drag(c: float, v_app: Vec3) -> Vec3:
    """Drag force (N) ``c |v_app| v_app`` along the apparent air velocity ``v_app`` (m/s)."""
    x, y, z = v_app
    k = c * math.sqrt(x * x + y * y + z * z)
    return (k * x, k * y, k * z)
