"""Quadratic wind drag on the vehicle's links (thesis §2.2.2 "wind-drag" plugin, docs/flight-models.md §2).

``F = c |V_app|² V_app/|V_app| = c |V_app| V_app`` with ``V_app = wind - v_link`` and
``c = ½ ρ S C_D0`` (kg/m). Any frame works as long as both vectors share it (the simulation
uses world ENU). With zero wind a climbing drone therefore feels drag pointing down.

A link whose centre of pressure sits at ``r`` from the centre of mass (world ENU) moves with
``v + ω × r``, so its air is ``V_app = (wind - v) - ω × r`` and its drag also turns the body:
``τ = r × F`` (:class:`BodyDrag`, what the loop applies every step).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import final

from vinecli.frames import BodyFrame, Vec3
from vinecli.specs.vehicle import DragLinkSpec

__all__ = ["BodyDrag", "apparent_velocity", "apparent_velocity_at", "body_drag", "wind_drag"]


def apparent_velocity(wind: Vec3, v_link: Vec3) -> Vec3:
    """``wind - v_link`` (m/s, same frame as the inputs)."""
    return (wind[0] - v_link[0], wind[1] - v_link[1], wind[2] - v_link[2])


def apparent_velocity_at(wind: Vec3, vel: Vec3, omega: Vec3, r: Vec3) -> Vec3:
    """Air at the point ``r`` (m from the centre of mass) of a rigid body moving at ``vel`` and turning
    at ``omega`` (rad/s): ``(wind - v) - ω × r`` (m/s; all vectors world ENU)."""
    ox, oy, oz = omega
    rx, ry, rz = r
    return (wind[0] - vel[0] - (oy * rz - oz * ry), wind[1] - vel[1] - (oz * rx - ox * rz),
            wind[2] - vel[2] - (ox * ry - oy * rx))


def wind_drag(c: float, v_app: Vec3) -> Vec3:
    """Drag force (N) ``c |v_app| v_app`` along the apparent air velocity ``v_app`` (m/s)."""
    x, y, z = v_app
    k = c * math.sqrt(x * x + y * y + z * z)
    return (k * x, k * y, k * z)


@final
class BodyDrag:
    """Wind drag of all links of a vehicle (module doc): the links centred on the centre of mass summed
    into one coefficient ``c_com`` (kg/m, no lever arm), the others kept with their lever arm.

    ``links``: (c kg/m, centre of pressure m body FLU) per link.
    """

    def __init__(self, links: list[tuple[float, Vec3]]) -> None:
        rows = [(float(c), float(r[0]), float(r[1]), float(r[2])) for c, r in links]
        self.c_com: float = sum((c for c, x, y, z in rows if x == y == z == 0.0), 0.0)
        #: (c kg/m, r_x, r_y, r_z m body FLU) of the links off the centre of mass
        self.arms: tuple[tuple[float, float, float, float], ...] = tuple(d for d in rows if d[1:] != (0.0, 0.0, 0.0))

    def wrench(self, frame: BodyFrame, vel: Vec3, omega: Vec3, wind: Vec3, torque: Vec3) -> tuple[Vec3, Vec3]:
        """(drag force N, torque N m), world ENU, for the body at attitude ``frame`` moving at ``vel`` (m/s)
        and turning at ``omega`` (rad/s, world) in ``wind`` (m/s). The links' torques ``r × F`` are added to
        ``torque`` (the torque already on the body) one by one, in link order."""
        dgx = dgy = dgz = 0.0
        if self.c_com > 0.0:
            dgx, dgy, dgz = wind_drag(self.c_com, apparent_velocity(wind, vel))
        tx, ty, tz = torque
        for c, bx, by, bz in self.arms:
            rx, ry, rz = frame.to_world(bx, by, bz)
            f0, f1, f2 = wind_drag(c, apparent_velocity_at(wind, vel, omega, (rx, ry, rz)))
            dgx += f0
            dgy += f1
            dgz += f2
            tx += ry * f2 - rz * f1
            ty += rz * f0 - rx * f2
            tz += rx * f1 - ry * f0
        return (dgx, dgy, dgz), (tx, ty, tz)


def body_drag(drag: Mapping[str, DragLinkSpec], air_density: float) -> BodyDrag:
    """The :class:`BodyDrag` of a vehicle's ``drag`` links (``c = ½ ρ S C_D0`` at ``air_density`` kg/m³)."""
    return BodyDrag([(d.coefficient(air_density), (float(d.position_m[0]), float(d.position_m[1]),
                                                   float(d.position_m[2]))) for d in drag.values()])
