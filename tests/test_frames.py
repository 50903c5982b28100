"""Property tests (hypothesis) for vinecli/frames.py: round trips and the thesis' conventions."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vinecli import frames as fr

finite = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False, allow_infinity=False)
vec3 = st.tuples(finite, finite, finite)
angle = st.floats(min_value=-math.pi, max_value=math.pi, allow_nan=False)
pitch = st.floats(min_value=-1.5, max_value=1.5, allow_nan=False)  # away from gimbal lock
comp = st.floats(min_value=-1.0, max_value=1.0, allow_nan=False)


@st.composite
def unit_quat(draw: st.DrawFn) -> fr.QuatXYZW:
    q = (draw(comp), draw(comp), draw(comp), draw(comp))
    n = math.sqrt(sum(c * c for c in q))
    if n < 1e-3:
        return fr.IDENTITY
    return fr.quat_normalize(q)


def _close(a, b, tol=1e-9) -> bool:
    return all(abs(x - y) <= tol * (1 + abs(y)) for x, y in zip(a, b, strict=True))


def _same_rotation(a: fr.QuatXYZW, b: fr.QuatXYZW, tol: float = 1e-12) -> bool:
    """q and -q are the same rotation: |<a, b>| = 1 for unit quaternions."""
    d = abs(sum(x * y for x, y in zip(fr.quat_normalize(a), fr.quat_normalize(b), strict=True)))
    return 1.0 - d <= tol


@given(vec3)
def test_enu_ned_round_trip(v: fr.Vec3) -> None:
    assert fr.ned_to_enu(fr.enu_to_ned(v)) == v
    assert fr.enu_to_ned(fr.ned_to_enu(v)) == v
    n = fr.enu_to_ned(v)
    assert n == (v[1], v[0], -v[2])


@given(vec3)
def test_flu_frd_round_trip(v: fr.Vec3) -> None:
    assert fr.frd_to_flu(fr.flu_to_frd(v)) == v
    assert fr.flu_to_frd(v) == (v[0], -v[1], -v[2])


@given(vec3)
def test_constant_quaternions_match_vector_maps(v: fr.Vec3) -> None:
    assert _close(fr.quat_rotate(fr.Q_NED_FROM_ENU, v), fr.enu_to_ned(v))
    assert _close(fr.quat_rotate(fr.Q_FRD_FROM_FLU, v), fr.flu_to_frd(v))


@given(unit_quat())
def test_xyzw_wxyz_round_trip(q: fr.QuatXYZW) -> None:
    assert fr.wxyz_to_xyzw(fr.xyzw_to_wxyz(q)) == q
    assert fr.xyzw_to_wxyz(q)[0] == q[3]


@given(angle, pitch, angle)
def test_quat_euler_round_trip(roll: float, p: float, yaw: float) -> None:
    q = fr.quat_from_euler(roll, p, yaw)
    assert math.isclose(sum(c * c for c in q), 1.0, rel_tol=1e-12)
    r2, p2, y2 = fr.quat_to_euler(q)
    assert _same_rotation(fr.quat_from_euler(r2, p2, y2), q)
    assert abs(fr.wrap_pi(r2 - roll)) < 1e-7 and abs(p2 - p) < 1e-7 and abs(fr.wrap_pi(y2 - yaw)) < 1e-7


@given(unit_quat())
def test_euler_of_any_quaternion_rebuilds_it(q: fr.QuatXYZW) -> None:
    r, p, y = fr.quat_to_euler(q)
    if abs(abs(p) - math.pi / 2) > 1e-3:
        assert _same_rotation(fr.quat_from_euler(r, p, y), q, 1e-10)


@given(unit_quat())
def test_attitude_enu_flu_ned_frd_round_trip(q: fr.QuatXYZW) -> None:
    q_ned = fr.attitude_enu_flu_to_ned_frd(q)
    assert _same_rotation(fr.attitude_ned_frd_to_enu_flu(q_ned), q)


@given(unit_quat(), vec3)
def test_attitude_conversion_is_consistent_with_vector_maps(q: fr.QuatXYZW, v_body: fr.Vec3) -> None:
    """Rotating a body vector then converting equals converting both then rotating."""
    q_ned = fr.attitude_enu_flu_to_ned_frd(q)
    lhs = fr.enu_to_ned(fr.quat_rotate(q, v_body))
    rhs = fr.quat_rotate(q_ned, fr.flu_to_frd(v_body))
    assert all(abs(a - b) < 1e-9 * (1 + abs(a)) for a, b in zip(lhs, rhs, strict=True))


@given(unit_quat(), vec3)
def test_rotate_inverse(q: fr.QuatXYZW, v: fr.Vec3) -> None:
    back = fr.quat_rotate_inv(q, fr.quat_rotate(q, v))
    assert all(abs(a - b) < 1e-9 * (1 + abs(b)) for a, b in zip(back, v, strict=True))
    m = fr.quat_to_matrix(q)
    mv = tuple(fr.dot(row, v) for row in m)
    assert all(abs(a - b) < 1e-9 * (1 + abs(b)) for a, b in zip(mv, fr.quat_rotate(q, v), strict=True))


@given(angle)
@settings(max_examples=200)
def test_yaw_heading_round_trip_and_attitude(yaw: float) -> None:
    h = fr.yaw_enu_to_heading_ned(yaw)
    assert 0.0 <= h < 2 * math.pi
    assert abs(fr.wrap_pi(fr.heading_ned_to_yaw_enu(h) - yaw)) < 1e-12
    # a level vehicle with ENU yaw ψ has NED heading π/2 - ψ, zero roll and pitch
    r, p, y = fr.quat_to_euler(fr.attitude_enu_flu_to_ned_frd(fr.quat_from_euler(0.0, 0.0, yaw)))
    assert abs(r) < 1e-9 or abs(abs(r) - 2 * math.pi) < 1e-9
    assert abs(p) < 1e-9
    assert abs(fr.wrap_pi(y - h)) < 1e-9


def test_identity_enu_flu_is_heading_east() -> None:
    q_ned = fr.attitude_enu_flu_to_ned_frd(fr.IDENTITY)
    roll, p, yaw = fr.quat_to_euler(q_ned)
    assert math.degrees(yaw) == pytest.approx(90.0)
    assert roll == pytest.approx(0.0, abs=1e-12) and p == pytest.approx(0.0, abs=1e-12)
    # nose (body x FLU) points east in ENU and east in NED
    assert fr.quat_rotate(q_ned, (1.0, 0.0, 0.0)) == pytest.approx((0.0, 1.0, 0.0), abs=1e-12)
    # body z FRD (down) points down in NED
    assert fr.quat_rotate(q_ned, (0.0, 0.0, 1.0)) == pytest.approx((0.0, 0.0, 1.0), abs=1e-12)
    assert math.degrees(fr.yaw_enu_to_heading_ned(0.0)) == pytest.approx(90.0)


def test_known_rotations() -> None:
    q = fr.quat_from_euler(0.0, 0.0, math.pi / 2)  # ENU yaw 90°: nose north
    assert fr.quat_rotate(q, (1.0, 0.0, 0.0)) == pytest.approx((0.0, 1.0, 0.0), abs=1e-12)
    assert math.degrees(fr.yaw_enu_to_heading_ned(math.pi / 2)) == pytest.approx(0.0, abs=1e-12)
    assert fr.tilt_angle(fr.quat_from_euler(0.3, 0.0, 1.0)) == pytest.approx(0.3)
    assert fr.cross((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)) == (0.0, 0.0, 1.0)
    assert fr.norm((3.0, 4.0, 12.0)) == 13.0


@given(unit_quat(), vec3)
def test_body_frame_matrix_rotates_as_the_quaternion(q: fr.QuatXYZW, v: fr.Vec3) -> None:
    frame = fr.BodyFrame()
    assert frame.to_world(*v) == v  # identity before any attitude is set
    frame.set(*q)
    rows = ((frame.r00, frame.r01, frame.r02), (frame.r10, frame.r11, frame.r12), (frame.r20, frame.r21, frame.r22))
    assert all(_close(a, b) for a, b in zip(rows, fr.quat_to_matrix(q), strict=True))
    assert _close(frame.to_world(*v), fr.quat_rotate(q, v))
    assert _close(frame.to_body(*v), fr.quat_rotate_inv(q, v))


@given(unit_quat(), vec3, st.floats(-0.1, 0.1))
def test_grid_convergence_at_the_firmware_boundary(q: fr.QuatXYZW, v: fr.Vec3, gamma: float) -> None:
    """World (CRS grid) -> true north by the convergence gamma: velocities and attitudes turn together (the body
    sees the same vector either way), the magnetic field turns back, and gamma 0 changes nothing, bit for bit."""
    true_q = fr.attitude_grid_to_ned_frd(q, gamma)
    # a body vector mapped to true NED through the rotated attitude = the world vector turned by gamma
    body = fr.quat_rotate_inv(q, v)
    via_att = fr.enu_to_ned(fr.quat_rotate(fr.attitude_ned_frd_to_enu_flu(true_q), body))
    assert _close(via_att, fr.grid_to_ned(v, gamma))
    assert _close(fr.true_enu_to_grid(fr.grid_to_true_enu(v, gamma), gamma), v)
    assert fr.grid_to_ned(v, 0.0) == fr.enu_to_ned(v)
    assert fr.attitude_grid_to_ned_frd(q, 0.0) == fr.attitude_enu_flu_to_ned_frd(q)


def test_grid_north_at_the_sample_field_is_west_of_true_north() -> None:
    """At Hancock (UTM 16N, west of its central meridian) the world's y axis points 1.77 deg west of true north:
    a vehicle facing world north heads 358.23 deg true."""
    gamma = math.radians(1.770)
    n, e, _ = fr.grid_to_ned((0.0, 1.0, 0.0), gamma)
    assert math.degrees(math.atan2(e, n)) % 360.0 == pytest.approx(358.23, abs=1e-6)
    yaw_north = fr.quat_from_euler(0.0, 0.0, math.pi / 2)
    _, _, heading = fr.quat_to_euler(fr.attitude_grid_to_ned_frd(yaw_north, gamma))
    assert math.degrees(heading) % 360.0 == pytest.approx(358.23, abs=1e-6)
