"""Quadratic wind drag F = c |V_app|² along V_app = wind - v_link."""

from __future__ import annotations

import math

import pytest

from vinecli.physics.aero import apparent_velocity, wind_drag
from vinecli.specs.vehicle import DragLinkSpec

C = 0.5 * 1.225 * 0.06 * 1.0  # x500 base: ½ ρ S C_D0


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_drag_magnitude_and_direction_each_axis(axis: int, sign: float) -> None:
    v = [0.0, 0.0, 0.0]
    v[axis] = 4.0 * sign  # body moves along one axis, wind calm
    f = wind_drag(C, apparent_velocity((0.0, 0.0, 0.0), tuple(v)))
    assert math.sqrt(sum(x * x for x in f)) == pytest.approx(C * 16.0, rel=1e-12)
    assert f[axis] == pytest.approx(-sign * C * 16.0, rel=1e-12)  # opposes the motion
    assert all(f[k] == 0.0 for k in range(3) if k != axis)


def test_drag_with_wind_and_velocity() -> None:
    wind = (3.0, -1.0, 0.5)
    vel = (1.0, 2.0, -1.5)
    v_app = apparent_velocity(wind, vel)
    assert v_app == (2.0, -3.0, 2.0)
    f = wind_drag(C, v_app)
    speed = math.sqrt(4 + 9 + 4)
    assert f == pytest.approx((C * speed * 2.0, -C * speed * 3.0, C * speed * 2.0), rel=1e-12)
    # parallel to V_app, magnitude c |V|²
    assert math.hypot(*f) == pytest.approx(C * speed**2, rel=1e-12)
    # a body moving with the wind feels nothing
    assert wind_drag(C, apparent_velocity(wind, wind)) == (0.0, 0.0, 0.0)


def test_zero_wind_climb_drag_points_down() -> None:
    f = wind_drag(C, apparent_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 2.0)))
    assert f[2] == pytest.approx(-C * 4.0) and f[0] == 0.0 and f[1] == 0.0


def test_coefficient_from_area_and_cd0() -> None:
    assert DragLinkSpec(area_m2=0.06, cd0=1.0).coefficient(1.225) == pytest.approx(0.03675)
    assert DragLinkSpec(coefficient_kg_per_m=0.05).coefficient(1.0) == 0.05


def test_terminal_speed_balance() -> None:
    """Falling at sqrt(m g / c) in still air the drag equals the weight."""
    m, g = 2.0, 9.80665
    v_t = math.sqrt(m * g / C)
    f = wind_drag(C, apparent_velocity((0.0, 0.0, 0.0), (0.0, 0.0, -v_t)))
    assert f[2] == pytest.approx(m * g, rel=1e-12)
