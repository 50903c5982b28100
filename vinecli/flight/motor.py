"""Multicopter motor/propeller model (docs/flight-models.md §1, Gazebo ``gazebo_motor_model.cpp``).

Per rotor i, body frame FLU, SI units:

* speed: first-order lag to the command, time constant ``tau_up_s`` when the command is above
  the current speed and ``tau_down_s`` otherwise, exact discretisation
  ``w += (1 - exp(-dt/tau)) (w_cmd - w)``, command clamped to ``[0, w_max]``;
* timing: :meth:`MotorBank.update` moves the speeds from ``t_k`` to ``t_k + dt`` and keeps the
  speeds at ``t_k`` in ``.w_start``; the forces of that step (held constant by the rigid-body
  step) use the exact means of the speed over the interval, ``w̄`` and ``mean(w²)``, so the
  impulse of a lagged rotor is the analytic one and the effective lag is exactly ``tau``
  (forces from the end-of-step speed would lag by ``tau - dt/2``);
* thrust ``T_i = k_f mean(w_i²)`` along the rotor axis ``a_i``;
* rotor drag (H-force) ``D_i = -k_d w_i V⊥`` and rolling moment ``M_i = -k_roll w_i V⊥``,
  where ``V⊥`` is the in-plane part of the rotor's velocity relative to the air
  (``v_rotor - wind`` = ``-v_app``), exactly as Gazebo-classic and gz-sim compute
  ``velocity_perpendicular_to_rotor_axis`` from ``body_velocity - wind``. So the H-force
  opposes the rotor's motion through the air, and the rolling moment is a torque vector along
  ``-V⊥`` (Gazebo's convention: no spin-direction factor, vector along the in-plane
  airspeed, not about the axis perpendicular to it);
* reaction torque ``Q_i = -s_i k_m T_i a_i`` with ``s = +1`` for CCW rotors: a CCW rotor yaws
  the body clockwise seen from above (negative z torque in FLU); the motors deliver the same
  torque, so the shaft power is ``sum k_m T_i w_i`` (``.shaft_power``, W).

The total wrench about the centre of mass adds ``r_i × (T_i a_i + D_i)``. Gazebo-classic's
extra thrust reduction ``(1 - v_axial/25)`` is not modelled (valid near hover, |V| < tip
speed / 7, rigid blades). Everything is plain floats (docs/flight-models.md §6): this runs every step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from vinecli.constants import STANDARD_GRAVITY
from vinecli.frames import QuatXYZW, Vec3, quat_rotate_inv
from vinecli.specs.vehicle import MotorSpec, RotorSpec

__all__ = ["MotorBank"]


class MotorBank:
    """All rotors of one vehicle: speeds, lag and the summed body wrench (FLU, about the CoM)."""

    def __init__(self, motor: MotorSpec, rotors: list[RotorSpec]) -> None:
        self.motor = motor
        self.n = len(rotors)
        self.k_f = float(motor.k_f)
        self.k_m = float(motor.k_m)
        self.k_d = float(motor.k_d)
        self.k_roll = float(motor.k_roll)
        self.w_max = float(motor.w_max)
        self.tau_up = float(motor.tau_up_s)
        self.tau_down = float(motor.tau_down_s)
        geo: list[tuple[float, float, float, float, float, float, float]] = []
        for r in rotors:
            ax, ay, az = (float(c) for c in r.axis)
            n = math.sqrt(ax * ax + ay * ay + az * az)
            if n <= 0.0:
                raise ValueError("rotor axis must be non-zero")
            px, py, pz = (float(c) for c in r.position_m)
            geo.append((px, py, pz, ax / n, ay / n, az / n, r.s))
        #: per rotor (px, py, pz, ax, ay, az, s): position m FLU, unit axis FLU, spin sign
        self.geometry = tuple(geo)
        self.positions: tuple[Vec3, ...] = tuple((g[0], g[1], g[2]) for g in geo)
        self._dt = -1.0
        self._a_up = 0.0
        self._a_down = 0.0
        self.w: list[float] = [0.0] * self.n
        #: speeds at the start of the last update's interval (rad/s): the value at the step's time
        self.w_start: tuple[float, ...] = (0.0,) * self.n
        #: interval means of w and w² the forces use (rad/s, rad²/s²), see the module docstring
        self.w_mean: list[float] = [0.0] * self.n
        self.w2_mean: list[float] = [0.0] * self.n
        self._b_up = self._b_down = self._c_up = self._c_down = 0.0
        self.thrust: list[float] = [0.0] * self.n
        self.thrust_total = 0.0
        self.rotor_drag_body: Vec3 = (0.0, 0.0, 0.0)
        self.reaction_torque_body: Vec3 = (0.0, 0.0, 0.0)
        self.rolling_moment_body: Vec3 = (0.0, 0.0, 0.0)
        #: mechanical power all rotors take from the motors, sum of k_m T_i w_i, W (last wrench)
        self.shaft_power = 0.0

    # ------------------------------------------------------------------ speed dynamics
    def reset(self, w0: float | Sequence[float] = 0.0) -> None:
        """Set the rotor speeds to ``w0`` rad/s (one for all or one per rotor; clamped to [0, w_max])."""
        ws = [float(w0)] * self.n if isinstance(w0, int | float) else [float(v) for v in w0]
        if len(ws) != self.n:
            raise ValueError(f"{len(ws)} rotor speeds for {self.n} rotors")
        self.w = [min(max(v, 0.0), self.w_max) for v in ws]
        self.w_start = tuple(self.w)
        self.w_mean = list(self.w)
        self.w2_mean = [v * v for v in self.w]

    def update(self, w_cmd: Sequence[float], dt: float) -> list[float]:
        """Advance the rotor speeds by ``dt`` s towards ``w_cmd`` (rad/s per rotor); returns ``.w``.

        ``w(s) = c + (w_k - c) e^(-s/tau)`` on the interval (``c`` = clamped command): ``.w`` is
        its end value, ``.w_start`` its start, ``.w_mean``/``.w2_mean`` its exact means of ``w`` and
        ``w²`` (what :meth:`wrench` uses).
        """
        if dt != self._dt:
            self._dt = dt
            e_up, e_down = math.exp(-dt / self.tau_up), math.exp(-dt / self.tau_down)
            self._a_up, self._a_down = 1.0 - e_up, 1.0 - e_down
            # means over [0, dt] of e^(-s/tau) and e^(-2s/tau)
            self._b_up, self._b_down = self.tau_up / dt * (1.0 - e_up), self.tau_down / dt * (1.0 - e_down)
            self._c_up = self.tau_up / (2.0 * dt) * (1.0 - e_up * e_up)
            self._c_down = self.tau_down / (2.0 * dt) * (1.0 - e_down * e_down)
        w_max = self.w_max
        e_up, e_down = 1.0 - self._a_up, 1.0 - self._a_down
        b_up, b_down, c_up, c_down = self._b_up, self._b_down, self._c_up, self._c_down
        w = self.w
        self.w_start = tuple(w)
        wm, w2m = self.w_mean, self.w2_mean
        for i in range(self.n):
            c = w_cmd[i]
            if c > w_max:
                c = w_max
            elif c < 0.0:
                c = 0.0
            wi = w[i]
            d = wi - c
            if c > wi:
                wi = c + d * e_up
                wm[i] = c + d * b_up
                w2m[i] = c * c + 2.0 * c * d * b_up + d * d * c_up
            else:
                wi = c + d * e_down
                wm[i] = c + d * b_down
                w2m[i] = c * c + 2.0 * c * d * b_down + d * d * c_down
            w[i] = w_max if wi > w_max else (0.0 if wi < 0.0 else wi)
        return w

    # ------------------------------------------------------------------ forces
    def apparent_air_body(self, quat: QuatXYZW, vel_enu: Vec3, omega_body: Vec3, wind_enu: Vec3) -> list[Vec3]:
        """Apparent air velocity at each rotor, ``wind - v_rotor``, in body FLU (m/s).

        ``v_rotor = R^T v_com + ω × r_i``; ``quat`` body FLU -> world ENU, ``omega_body`` rad/s FLU.
        """
        bx, by, bz = quat_rotate_inv(
            quat, (wind_enu[0] - vel_enu[0], wind_enu[1] - vel_enu[1], wind_enu[2] - vel_enu[2])
        )
        wx, wy, wz = omega_body
        out = []
        for px, py, pz, *_ in self.geometry:
            # minus (omega x r)
            out.append((bx - (wy * pz - wz * py), by - (wz * px - wx * pz), bz - (wx * py - wy * px)))
        return out

    def wrench(self, v_app_body: Sequence[Vec3] | None = None) -> tuple[Vec3, Vec3]:
        """Total (force N, torque N m) in body FLU about the CoM.

        ``v_app_body[i]`` is the apparent air velocity at rotor i (``wind - v_rotor``, body FLU,
        m/s); ``None`` means still air and a vehicle at rest (thrust and reaction torque only).
        Also stores ``.thrust``, ``.thrust_total``, ``.rotor_drag_body``,
        ``.reaction_torque_body`` and ``.rolling_moment_body`` for recording.
        """
        return self._wrench(v_app_body, v_app_body is not None, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def wrench_com(self, bx: float, by: float, bz: float, wx: float, wy: float, wz: float) -> tuple[Vec3, Vec3]:
        """:meth:`wrench` for the apparent air at the CoM ``(bx, by, bz)`` (``wind - v``, body FLU, m/s)
        and body rates ``(wx, wy, wz)`` (rad/s FLU): at rotor i the air is ``b - ω × r_i``. The loop's
        form: the same numbers as ``wrench(apparent_air_body(...))`` without per-rotor lists."""
        return self._wrench(None, True, bx, by, bz, wx, wy, wz)

    def _wrench(self, v_app_body: Sequence[Vec3] | None, moving: bool, bx: float, by: float, bz: float,
                wx: float, wy: float, wz: float) -> tuple[Vec3, Vec3]:
        k_f, k_m, k_d, k_roll = self.k_f, self.k_m, self.k_d, self.k_roll
        w, w2 = self.w_mean, self.w2_mean
        thrust = self.thrust
        fx = fy = fz = 0.0
        tx = ty = tz = 0.0
        dx = dy = dz = 0.0
        qx = qy = qz = 0.0
        mx = my = mz = 0.0
        tsum = psum = 0.0
        for i, (px, py, pz, ax, ay, az, s) in enumerate(self.geometry):
            wi = w[i]
            t = k_f * w2[i]
            thrust[i] = t
            tsum += t
            psum += t * wi
            f0, f1, f2 = t * ax, t * ay, t * az
            if moving:
                if v_app_body is not None:
                    vx, vy, vz = v_app_body[i]
                else:  # minus (omega x r)
                    vx, vy, vz = bx - (wy * pz - wz * py), by - (wz * px - wx * pz), bz - (wx * py - wy * px)
                va = vx * ax + vy * ay + vz * az
                # in-plane apparent air velocity; V⊥ of (v_rotor - wind) is its negative
                ux, uy, uz = vx - va * ax, vy - va * ay, vz - va * az
                kd = k_d * wi
                hx, hy, hz = kd * ux, kd * uy, kd * uz  # = -k_d w V⊥
                dx += hx
                dy += hy
                dz += hz
                f0 += hx
                f1 += hy
                f2 += hz
                kr = k_roll * wi
                mx += kr * ux
                my += kr * uy
                mz += kr * uz
            q = -s * k_m * t
            qx += q * ax
            qy += q * ay
            qz += q * az
            fx += f0
            fy += f1
            fz += f2
            tx += py * f2 - pz * f1
            ty += pz * f0 - px * f2
            tz += px * f1 - py * f0
        self.thrust_total = tsum
        self.shaft_power = k_m * psum
        self.rotor_drag_body = (dx, dy, dz)
        self.reaction_torque_body = (qx, qy, qz)
        self.rolling_moment_body = (mx, my, mz)
        return (fx, fy, fz), (tx + qx + mx, ty + qy + my, tz + qz + mz)

    # ------------------------------------------------------------------ helpers
    def hover_speed(self, total_mass: float, g: float = STANDARD_GRAVITY) -> float:
        """Steady hover speed ``sqrt(m g / (n k_f))`` in rad/s (all axes vertical)."""
        return math.sqrt(total_mass * g / (self.n * self.k_f))
