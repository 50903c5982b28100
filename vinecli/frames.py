"""Frame and quaternion conventions: the only module that flips signs.

Inside vinecli: world **ENU** (x east, y north, z up), body **FLU** (x forward, y left,
z up), quaternions ``(x, y, z, w)`` as PyBullet uses them, all in SI units.
At the PX4/MAVLink boundary: world **NED**, body **FRD**, quaternions ``(w, x, y, z)``.

Constants (thesis §4.2.5):

* ``Q_NED_FROM_ENU`` = (w, x, y, z) (0, √½, √½, 0): rotates ENU vectors into NED.
* ``Q_FRD_FROM_FLU`` = (w, x, y, z) (0, 1, 0, 0): 180° about x, its own inverse.

Functions take and return plain tuples of floats: they run in the 250 Hz loop, where a
numpy call on a 3-vector costs 10× a few float operations (docs/flight-models.md §6).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, final

if TYPE_CHECKING:
    import numpy as np

Vec3 = tuple[float, float, float]
QuatXYZW = tuple[float, float, float, float]
QuatWXYZ = tuple[float, float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]

_S = math.sqrt(0.5)
#: NED <- ENU rotation, (x, y, z, w) order.
Q_NED_FROM_ENU: QuatXYZW = (_S, _S, 0.0, 0.0)
#: FRD <- FLU rotation (= FLU <- FRD), (x, y, z, w) order.
Q_FRD_FROM_FLU: QuatXYZW = (1.0, 0.0, 0.0, 0.0)
IDENTITY: QuatXYZW = (0.0, 0.0, 0.0, 1.0)


# ---------------------------------------------------------------- vectors between conventions
def enu_to_ned(v: Vec3) -> Vec3:
    """World vector ENU (e, n, u) -> NED (n, e, -u)."""
    return (v[1], v[0], -v[2])


def ned_to_enu(v: Vec3) -> Vec3:
    """World vector NED (n, e, d) -> ENU (e, n, -d)."""
    return (v[1], v[0], -v[2])


def flu_to_frd(v: Vec3) -> Vec3:
    """Body vector FLU -> FRD: (x, -y, -z)."""
    return (v[0], -v[1], -v[2])


def frd_to_flu(v: Vec3) -> Vec3:
    """Body vector FRD -> FLU: (x, -y, -z)."""
    return (v[0], -v[1], -v[2])


# ---------------------------------------------------------------- quaternion algebra (x, y, z, w)
def quat_mul(a: QuatXYZW, b: QuatXYZW) -> QuatXYZW:
    """Hamilton product a ⊗ b, both (x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_conj(q: QuatXYZW) -> QuatXYZW:
    """Conjugate (inverse of a unit quaternion)."""
    return (-q[0], -q[1], -q[2], q[3])


def quat_normalize(q: QuatXYZW) -> QuatXYZW:
    """Unit quaternion with w >= 0 (canonical sign)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    s = 1.0 / n if q[3] >= 0 else -1.0 / n
    return (q[0] * s, q[1] * s, q[2] * s, q[3] * s)


def quat_rotate(q: QuatXYZW, v: Vec3) -> Vec3:
    """Rotate vector v by unit quaternion q (x, y, z, w): q v q*."""
    qx, qy, qz, qw = q
    vx, vy, vz = v
    # t = 2 * (q_vec x v)
    tx = 2.0 * (qy * vz - qz * vy)
    ty = 2.0 * (qz * vx - qx * vz)
    tz = 2.0 * (qx * vy - qy * vx)
    return (
        vx + qw * tx + (qy * tz - qz * ty),
        vy + qw * ty + (qz * tx - qx * tz),
        vz + qw * tz + (qx * ty - qy * tx),
    )


def quat_rotate_many(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vectorised :func:`quat_rotate`: quaternions ``q`` (N, 4) xyzw rotate vectors ``v`` (3,) or (N, 3).

    Body FLU -> world ENU when ``q`` is the body attitude. Returns (N, 3).
    """
    import numpy as np

    q = np.asarray(q, dtype=np.float64)
    v = np.broadcast_to(np.asarray(v, dtype=np.float64), (q.shape[0], 3))
    qv, qw = q[:, :3], q[:, 3:4]
    t = 2.0 * np.cross(qv, v)
    return v + qw * t + np.cross(qv, t)


def quat_rotate_inv(q: QuatXYZW, v: Vec3) -> Vec3:
    """Rotate v by the inverse of q: world -> body when q is body -> world."""
    return quat_rotate((-q[0], -q[1], -q[2], q[3]), v)


def quat_to_matrix(q: QuatXYZW) -> Mat3:
    """Rotation matrix (rows) of unit quaternion q (x, y, z, w)."""
    x, y, z, w = q
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    return (
        (1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy)),
        (2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx)),
        (2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy)),
    )


@final
class BodyFrame:
    """The rotation body FLU -> world ENU of one attitude as a matrix (rows ``r0*``, ``r1*``, ``r2*``): set
    once (:meth:`set`), then rotate many vectors cheaply (the loop: once per physics step)."""

    def __init__(self) -> None:
        self.r00, self.r01, self.r02 = 1.0, 0.0, 0.0
        self.r10, self.r11, self.r12 = 0.0, 1.0, 0.0
        self.r20, self.r21, self.r22 = 0.0, 0.0, 1.0

    def set(self, qx: float, qy: float, qz: float, qw: float) -> None:
        """The attitude: unit quaternion (x, y, z, w) body FLU -> world ENU."""
        xx, yy, zz = qx * qx, qy * qy, qz * qz
        xy, xz, yz = qx * qy, qx * qz, qy * qz
        wx, wy, wz = qw * qx, qw * qy, qw * qz
        self.r00, self.r01, self.r02 = 1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy)
        self.r10, self.r11, self.r12 = 2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx)
        self.r20, self.r21, self.r22 = 2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy)

    def to_world(self, x: float, y: float, z: float) -> Vec3:
        """Body FLU vector -> world ENU (``R v``)."""
        return (self.r00 * x + self.r01 * y + self.r02 * z, self.r10 * x + self.r11 * y + self.r12 * z,
                self.r20 * x + self.r21 * y + self.r22 * z)

    def to_body(self, x: float, y: float, z: float) -> Vec3:
        """World ENU vector -> body FLU (``Rᵀ v``)."""
        return (self.r00 * x + self.r10 * y + self.r20 * z, self.r01 * x + self.r11 * y + self.r21 * z,
                self.r02 * x + self.r12 * y + self.r22 * z)


def quat_from_axis_angle(axis: Vec3, angle: float) -> QuatXYZW:
    """Quaternion (x, y, z, w) for a rotation of ``angle`` rad about unit ``axis``."""
    s = math.sin(angle / 2.0)
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2.0))


def quat_from_euler(roll: float, pitch: float, yaw: float) -> QuatXYZW:
    """Quaternion (x, y, z, w) from intrinsic Z-Y-X Euler angles (rad): yaw, then pitch, then roll."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def quat_to_euler(q: QuatXYZW) -> Vec3:
    """(roll, pitch, yaw) in rad, Z-Y-X convention, from (x, y, z, w).

    In ENU/FLU yaw is measured from east, counter-clockwise; in NED/FRD from north, clockwise.
    """
    x, y, z, w = q
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    sp = 2 * (w * y - z * x)
    pitch = math.copysign(math.pi / 2, sp) if abs(sp) >= 1 else math.asin(sp)
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return (roll, pitch, yaw)


def tilt_angle(q: QuatXYZW) -> float:
    """Angle (rad) between the body z axis and the world vertical."""
    x, y, _z, _w = q
    c = 1 - 2 * (x * x + y * y)
    return math.acos(max(-1.0, min(1.0, c)))


# ---------------------------------------------------------------- quaternion order
def xyzw_to_wxyz(q: QuatXYZW) -> QuatWXYZ:
    """PyBullet order -> MAVLink order."""
    return (q[3], q[0], q[1], q[2])


def wxyz_to_xyzw(q: QuatWXYZ) -> QuatXYZW:
    """MAVLink order -> PyBullet order."""
    return (q[1], q[2], q[3], q[0])


# ---------------------------------------------------------------- attitude between conventions
def attitude_enu_flu_to_ned_frd(q_enu_flu: QuatXYZW) -> QuatXYZW:
    """Body attitude q_ENU<-FLU -> q_NED<-FRD (both x, y, z, w).

    q_NED<-FRD = q_NED<-ENU ⊗ q_ENU<-FLU ⊗ q_FLU<-FRD.
    """
    return quat_normalize(quat_mul(quat_mul(Q_NED_FROM_ENU, q_enu_flu), Q_FRD_FROM_FLU))


def attitude_ned_frd_to_enu_flu(q_ned_frd: QuatXYZW) -> QuatXYZW:
    """Inverse of :func:`attitude_enu_flu_to_ned_frd`."""
    return quat_normalize(quat_mul(quat_mul(quat_conj(Q_NED_FROM_ENU), q_ned_frd), Q_FRD_FROM_FLU))


# ---------------------------------------------------------------- the world's grid and true north
def grid_to_true_enu(v: Vec3, gamma: float) -> Vec3:
    """World vector (ENU along a CRS grid) -> true ENU: rotated by the grid convergence ``gamma`` (rad,
    counter-clockwise from true east to the world's x axis, :attr:`vinecli.geo.GeoOrigin.convergence_rad`);
    unchanged for ``gamma`` 0 (worlds without a CRS)."""
    if gamma == 0.0:
        return v
    c, s = math.cos(gamma), math.sin(gamma)
    return (c * v[0] - s * v[1], s * v[0] + c * v[1], v[2])


def grid_to_ned(v: Vec3, gamma: float) -> Vec3:
    """World vector -> NED against true north (velocities and offsets at the firmware boundary)."""
    return enu_to_ned(grid_to_true_enu(v, gamma))


def true_enu_to_grid(v: Vec3, gamma: float) -> Vec3:
    """Inverse of :func:`grid_to_true_enu` (e.g. the Earth's magnetic field into the world)."""
    return grid_to_true_enu(v, -gamma)


def attitude_grid_to_ned_frd(q_world_flu: QuatXYZW, gamma: float) -> QuatXYZW:
    """Body attitude in the world (q_world<-FLU, x, y, z, w) -> q_NED<-FRD against true north: the firmware
    boundary's attitude (:func:`attitude_enu_flu_to_ned_frd` after rotating by the grid convergence)."""
    if gamma == 0.0:
        return attitude_enu_flu_to_ned_frd(q_world_flu)
    return attitude_enu_flu_to_ned_frd(quat_mul(quat_from_axis_angle((0.0, 0.0, 1.0), gamma), q_world_flu))


def yaw_enu_to_heading_ned(yaw_enu: float) -> float:
    """ENU yaw (rad from east, CCW) -> NED heading (rad from north, CW), wrapped to [0, 2π)."""
    return (math.pi / 2 - yaw_enu) % (2 * math.pi)


def heading_ned_to_yaw_enu(heading: float) -> float:
    """NED heading (rad from north, CW) -> ENU yaw (rad from east, CCW), wrapped to (-π, π]."""
    return wrap_pi(math.pi / 2 - heading)


def wrap_pi(a: float) -> float:
    """Wrap an angle to (-π, π]."""
    a = math.fmod(a + math.pi, 2 * math.pi)
    if a <= 0:
        a += 2 * math.pi
    return a - math.pi


# ---------------------------------------------------------------- small vector helpers (plain floats)
def cross(a: Vec3, b: Vec3) -> Vec3:
    """a × b."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a: Vec3, b: Vec3) -> float:
    """a · b."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def norm(a: Vec3) -> float:
    """|a|."""
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
