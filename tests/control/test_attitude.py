"""Attitude setpoint and quaternion attitude control: signs, yaw weighting, convergence."""

from __future__ import annotations

import math

import pytest

from vinecli.control.cascade import attitude_rate_setpoint, matrix_columns_to_quat, thrust_to_attitude
from vinecli.frames import quat_from_euler, quat_mul, quat_normalize, quat_rotate, quat_to_euler, tilt_angle

GAIN = (6.5, 6.5, 2.8)


def test_vertical_thrust_gives_the_heading_only() -> None:
    for yaw in (0.0, 0.7, -2.5, math.pi):
        q = thrust_to_attitude(0.0, 0.0, 20.0, yaw)
        r, p, y = quat_to_euler(q)
        assert r == pytest.approx(0.0, abs=1e-12)
        assert p == pytest.approx(0.0, abs=1e-12)
        assert math.cos(y - yaw) == pytest.approx(1.0)


def test_tilted_thrust_sets_body_z_and_keeps_heading() -> None:
    f = (3.0, -2.0, 15.0)
    yaw = 0.4
    q = thrust_to_attitude(*f, yaw)
    bz = quat_rotate(q, (0.0, 0.0, 1.0))
    n = math.sqrt(sum(c * c for c in f))
    assert bz == pytest.approx(tuple(c / n for c in f))
    bx = quat_rotate(q, (1.0, 0.0, 0.0))
    assert math.atan2(bx[1], bx[0]) == pytest.approx(yaw, abs=0.05)
    # thrust towards +x east with heading east: nose down = positive pitch (FLU about y)
    q2 = thrust_to_attitude(2.0, 0.0, 10.0, 0.0)
    assert quat_to_euler(q2)[1] == pytest.approx(math.atan2(2.0, 10.0))


def test_matrix_to_quaternion_round_trip() -> None:
    for rpy in [(0.1, -0.2, 0.3), (2.9, 0.1, -3.0), (0.0, 1.5, 0.0), (-3.1, -0.4, 1.6)]:
        q = quat_from_euler(*rpy)
        cols = [quat_rotate(q, e) for e in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))]
        q2 = matrix_columns_to_quat(*cols)
        assert q2 == pytest.approx(quat_normalize(q), abs=1e-9)


@pytest.mark.parametrize("axis, angle", [(0, 0.1), (0, -0.2), (1, 0.15), (1, -0.1)])
def test_roll_pitch_error_commands_rate_towards_setpoint(axis: int, angle: float) -> None:
    rpy = [0.0, 0.0, 0.0]
    rpy[axis] = angle
    rate = attitude_rate_setpoint((0.0, 0.0, 0.0, 1.0), quat_from_euler(*rpy), GAIN, 0.4)
    assert rate[axis] == pytest.approx(GAIN[axis] * 2.0 * math.sin(angle / 2.0), rel=1e-6)
    assert abs(rate[1 - axis]) < 1e-9 and abs(rate[2]) < 1e-9


def test_yaw_error_uses_the_yaw_gain() -> None:
    # the yaw weight scales the yaw part of the error and PX4 divides the gain by it: the
    # small-angle yaw rate is K_yaw * error
    rate = attitude_rate_setpoint((0.0, 0.0, 0.0, 1.0), quat_from_euler(0.0, 0.0, 0.05), GAIN, 0.4)
    assert rate[2] == pytest.approx(GAIN[2] * 0.05, rel=1e-3)
    assert abs(rate[0]) < 1e-12 and abs(rate[1]) < 1e-12


def test_large_yaw_error_follows_the_px4_weighting() -> None:
    # pure yaw error psi: PX4 rotates by yaw_w * psi and divides the gain by yaw_w
    psi, w, k = 1.2, 0.4, 2.8
    rate = attitude_rate_setpoint((0.0, 0.0, 0.0, 1.0), quat_from_euler(0.0, 0.0, psi), (6.5, 6.5, k), w)
    assert rate[2] == pytest.approx(2.0 * math.sin(w * psi / 2.0) * k / w, rel=1e-9)


@pytest.mark.parametrize("target", [(0.5, -0.3, 2.0), (-1.2, 0.4, -2.8), (3.0, 0.0, 0.0), (0.0, 0.0, 3.1)])
def test_attitude_loop_converges_kinematically(target: tuple[float, float, float]) -> None:
    # integrate q_dot = 1/2 q (x) omega with omega = the rate setpoint: reaches the setpoint
    qd = quat_from_euler(*target)
    q = quat_from_euler(0.05, -0.02, 0.0)
    dt = 0.002
    for _ in range(5000):
        w = attitude_rate_setpoint(q, qd, GAIN, 0.4)
        dq = quat_mul(q, (w[0] * dt / 2, w[1] * dt / 2, w[2] * dt / 2, 1.0))
        q = quat_normalize(dq)
    err = quat_mul((-q[0], -q[1], -q[2], q[3]), qd)
    assert abs(err[3]) == pytest.approx(1.0, abs=1e-6)
    assert tilt_angle(q) == pytest.approx(tilt_angle(qd), abs=1e-3)
