"""Quadratic wind drag F = c |V_app|² along V_app = wind - v_link, and the links of a body with their lever arms."""

from __future__ import annotations

import math

import pytest

from vinecli.flight.aero import BodyDrag, apparent_velocity, apparent_velocity_at, body_drag, wind_drag
from vinecli.frames import BodyFrame, quat_rotate
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


def _cross(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def test_air_at_a_point_of_a_turning_body() -> None:
    """V_app = wind - (v + ω × r): a point ahead of the CoM of a body yawing left moves to the left."""
    v = apparent_velocity_at((1.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 2.0), (0.5, 0.0, 0.0))
    assert v == pytest.approx((1.0, -1.0, 0.0))


def test_body_drag_sums_links_with_their_lever_arms() -> None:
    """F = Σ c_j |V_j| V_j, τ = τ_0 + Σ r_j × F_j with r_j rotated into the world and V_j at r_j."""
    links = [(0.03, (0.0, 0.0, 0.0)), (0.01, (0.0, 0.0, -0.06)), (0.02, (0.2, 0.1, 0.0))]
    drag = BodyDrag(links)
    assert drag.c_com == 0.03 and len(drag.arms) == 2
    yaw = math.radians(30.0)
    q = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
    frame = BodyFrame()
    frame.set(*q)
    wind, vel, omega, torque0 = (3.0, -1.0, 0.5), (1.0, 2.0, -0.5), (0.1, -0.2, 0.4), (0.3, 0.0, -0.1)
    force, torque = drag.wrench(frame, vel, omega, wind, torque0)
    f_exp = list(wind_drag(0.03, apparent_velocity(wind, vel)))
    t_exp = list(torque0)
    for c, r_body in links[1:]:
        r = quat_rotate(q, r_body)
        v_app = tuple(w - u - x for w, u, x in zip(wind, vel, _cross(omega, r), strict=True))
        f = tuple(c * math.hypot(*v_app) * x for x in v_app)
        f_exp = [a + b for a, b in zip(f_exp, f, strict=True)]
        t_exp = [a + b for a, b in zip(t_exp, _cross(r, f), strict=True)]
    assert force == pytest.approx(f_exp, rel=1e-12) and torque == pytest.approx(t_exp, rel=1e-12)


def test_body_drag_of_a_vehicle_spec() -> None:
    drag = body_drag({"base": DragLinkSpec(area_m2=0.06, cd0=1.0),
                      "tank": DragLinkSpec(area_m2=0.02, cd0=0.8, position_m=(0.0, 0.0, -0.06))}, 1.225)
    assert drag.c_com == pytest.approx(0.5 * 1.225 * 0.06) and drag.arms == ((pytest.approx(0.5 * 1.225 * 0.016),
                                                                            0.0, 0.0, -0.06),)
    still = BodyFrame()
    force, torque = drag.wrench(still, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert force == (0.0, 0.0, 0.0) and torque == (0.0, 0.0, 0.0)  # no air, no drag
