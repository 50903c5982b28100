"""Control allocation (mixer) for multirotors from the vehicle spec.

Effectiveness matrix ``B`` (4 x n) maps rotor thrusts ``T_i`` (N) to the collective thrust
along body z (N) and the body torques (N m, FLU) about the centre of mass::

    thrust = sum_i a_i.z T_i
    torque = sum_i (r_i x a_i) T_i - s_i k_m a_i T_i        (s_i = +1 CCW, -1 CW)

with ``r_i`` the rotor position, ``a_i`` its thrust axis. The mixer is the pseudo-inverse
``M = pinv(B)`` (n x 4), computed once with numpy; :meth:`Mixer.allocate` runs in plain
floats. Rotor thrusts are limited to ``[k_f w_min_armed², k_f w_max²]``; when the unconstrained
solution does not fit, the PX4 "airmode off" sequential desaturation
(``ControlAllocationSequentialDesaturation::mixAirmodeDisabled``) is applied: thrust may only
be reduced, then roll and pitch are reduced, and yaw is mixed last with the lowest priority:
the largest share of the yaw request that fits is used (PX4's 15 % headroom + thrust
reduction when that gives more yaw without clipping), so roll and pitch are never distorted
by yaw.
Rotor speed commands are ``sqrt(T_i / k_f)`` clamped to ``[w_min_armed, w_max]`` (rad/s).

Normalised torques (the rate controller's output, PX4 style) are converted with
:attr:`Mixer.torque_scale`: 1.0 about x/y is the torque of a full one-sided thrust
difference at half collective (``sum |r_y| T_max / 2``), about z the reaction torque
``sum k_m T_max / 2``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from vinecli.errors import SpecError
from vinecli.specs.vehicle import MotorSpec, RotorSpec, VehicleSpec

_EPS = 1e-9


def effectiveness_matrix(motor: MotorSpec, rotors: Sequence[RotorSpec]) -> np.ndarray:
    """``B`` (4 x n): rows thrust (N), roll, pitch, yaw torque (N m) per newton of rotor thrust."""
    cols = []
    for r in rotors:
        ax, ay, az = r.axis
        n = math.sqrt(ax * ax + ay * ay + az * az)
        ax, ay, az = ax / n, ay / n, az / n
        px, py, pz = r.position_m
        tx = py * az - pz * ay
        ty = pz * ax - px * az
        tz = px * ay - py * ax
        s = r.s
        cols.append((az, tx - s * motor.k_m * ax, ty - s * motor.k_m * ay, tz - s * motor.k_m * az))
    return np.array(cols, dtype=float).T


class Mixer:
    """Rotor thrust allocation with saturation handling; see the module docstring.

    After :meth:`allocate`, :attr:`saturation` holds (thrust, roll, pitch, yaw) flags:
    +1 when the achieved value is below the request (saturated upwards), -1 below, 0 none;
    :attr:`thrusts` the rotor thrusts (N).
    """

    def __init__(self, vehicle: VehicleSpec) -> None:
        motor = vehicle.motor
        self.n = vehicle.n_rotors
        self.k_f = motor.k_f
        self.w_min = motor.w_min_armed
        self.w_max = motor.w_max
        self.t_min = motor.k_f * motor.w_min_armed**2
        self.t_max = motor.k_f * motor.w_max**2
        b = effectiveness_matrix(motor, vehicle.rotors)
        if np.linalg.matrix_rank(b) < 4:
            raise SpecError(f"vehicle {vehicle.name!r}: rotor layout cannot control thrust, roll, pitch and yaw independently")
        m = np.linalg.pinv(b)
        self.B: tuple[tuple[float, ...], ...] = tuple(tuple(float(x) for x in row) for row in b)
        self.M: tuple[tuple[float, ...], ...] = tuple(tuple(float(x) for x in row) for row in m)  # n x 4
        self.col_thrust = tuple(float(x) for x in m[:, 0])
        self.col_roll = tuple(float(x) for x in m[:, 1])
        self.col_pitch = tuple(float(x) for x in m[:, 2])
        self.col_yaw = tuple(float(x) for x in m[:, 3])
        self.torque_scale: tuple[float, float, float] = (
            sum(abs(r.position_m[1]) for r in vehicle.rotors) * self.t_max / 2.0,
            sum(abs(r.position_m[0]) for r in vehicle.rotors) * self.t_max / 2.0,
            self.n * motor.k_m * self.t_max / 2.0,
        )
        self.saturation: tuple[int, int, int, int] = (0, 0, 0, 0)
        self.thrusts: list[float] = [0.0] * self.n

    # ------------------------------------------------------------------ desaturation helpers
    def _gain(self, vec: Sequence[float], sp: list[float], t_max: float) -> float:
        """PX4 computeDesaturationGain: k so that sp + k vec is back within [t_min, t_max]."""
        k_min = 0.0
        k_max = 0.0
        t_min = self.t_min
        for i in range(self.n):
            v = vec[i]
            if -_EPS < v < _EPS:
                continue
            s = sp[i]
            if s < t_min:
                k = (t_min - s) / v
                if k < k_min:
                    k_min = k
                if k > k_max:
                    k_max = k
            if s > t_max:
                k = (t_max - s) / v
                if k < k_min:
                    k_min = k
                if k > k_max:
                    k_max = k
        return k_min + k_max

    def _desaturate(self, sp: list[float], vec: Sequence[float], t_max: float, reduce_only: bool = False) -> None:
        """PX4 desaturateActuators (``reduce_only``: the vector may only be subtracted)."""
        k = self._gain(vec, sp, t_max)
        if reduce_only and k > 0.0:
            return
        n = self.n
        for i in range(n):
            sp[i] = sp[i] + (k * vec[i])
        k = 0.5 * self._gain(vec, sp, t_max)
        if reduce_only and k > 0.0:
            return
        for i in range(n):
            sp[i] = sp[i] + (k * vec[i])

    def _yaw_share(self, sp: Sequence[float], yaw: Sequence[float], t_max: float) -> float:
        """Largest k in [0, 1] with t_min <= sp + k yaw <= t_max for every rotor."""
        k = 1.0
        t_min = self.t_min
        for s, y in zip(sp, yaw, strict=True):
            if y > _EPS:
                lim = (t_max - s) / y
            elif y < -_EPS:
                lim = (t_min - s) / y
            else:
                continue
            if lim < k:
                k = lim
        return k if k > 0.0 else 0.0

    # ------------------------------------------------------------------ main entry
    def allocate_thrusts(self, thrust: float, tx: float, ty: float, tz: float) -> list[float]:
        """Rotor thrusts (N) for collective ``thrust`` (N) and torques (N m, body FLU)."""
        t_min, t_max = self.t_min, self.t_max
        sp = [m0 * thrust + m1 * tx + m2 * ty + m3 * tz for m0, m1, m2, m3 in self.M]
        for s in sp:
            if s < t_min or s > t_max:
                break
        else:
            self.saturation = (0, 0, 0, 0)
            self.thrusts = sp
            return sp
        # sequential desaturation, PX4 airmode disabled
        ct, cr, cp, cy = self.col_thrust, self.col_roll, self.col_pitch, self.col_yaw
        n = self.n
        sp = [ct[i] * thrust + cr[i] * tx + cp[i] * ty for i in range(n)]
        self._desaturate(sp, ct, t_max, reduce_only=True)
        self._desaturate(sp, cr, t_max)
        self._desaturate(sp, cp, t_max)
        yaw = [cy[i] * tz for i in range(n)]
        # (a) the largest share of the yaw request that fits without touching anything else
        k_a = self._yaw_share(sp, yaw, t_max)
        if k_a < 1.0:
            # (b) PX4 mixYaw: 15 % headroom above the top for yaw, then thrust reduced; used
            # only when it gives more yaw and needs no clipping at the bottom
            hi = t_max + 0.15 * (t_max - t_min)
            k_b = self._yaw_share(sp, yaw, hi)
            if k_b > k_a:
                cand = [sp[i] + k_b * yaw[i] for i in range(n)]
                self._desaturate(cand, ct, t_max, reduce_only=True)
                if min(cand) >= t_min - 1e-9 and max(cand) <= t_max + 1e-9:
                    sp = cand
                    k_a = -1.0
        if k_a >= 0.0:
            for i in range(n):
                sp[i] = sp[i] + (k_a * yaw[i])
        for i in range(n):
            s = sp[i]
            sp[i] = t_min if s < t_min else (t_max if s > t_max else s)
        # saturation flags from what is actually achieved
        req = (thrust, tx, ty, tz)
        flags = []
        for row, r in zip(self.B, req, strict=True):
            got = 0.0
            for b, s in zip(row, sp, strict=True):
                got += b * s
            tol = 1e-6 * (1.0 + abs(r))
            flags.append(1 if got < r - tol else (-1 if got > r + tol else 0))
        self.saturation = (flags[0], flags[1], flags[2], flags[3])
        self.thrusts = sp
        return sp

    def rotor_speeds(self, thrusts: Sequence[float]) -> tuple[float, ...]:
        """Rotor speed commands sqrt(T/k_f) clamped to [w_min_armed, w_max], rad/s."""
        inv = 1.0 / self.k_f
        w_min, w_max = self.w_min, self.w_max
        out = []
        for t in thrusts:
            w = math.sqrt(t * inv) if t > 0.0 else 0.0
            out.append(w_min if w < w_min else (w_max if w > w_max else w))
        return tuple(out)

    def allocate(self, thrust: float, tx: float, ty: float, tz: float) -> tuple[float, ...]:
        """Rotor speed commands (rad/s) for collective thrust (N) and torques (N m, FLU)."""
        return self.rotor_speeds(self.allocate_thrusts(thrust, tx, ty, tz))
