"""Dryden turbulence, MIL-F-8785C low-altitude form, as exact discrete-time filters.

Scale lengths and intensities (h = height above ground in **feet**, clamped to [10, 1000]):

* ``L_w = h``, ``L_u = L_v = h / (0.177 + 0.000823 h)^1.2``
* ``σ_w = 0.1 W20``, ``σ_u = σ_v = σ_w / (0.177 + 0.000823 h)^0.4``

with W20 the mean wind at 20 ft (6 m): light 15 kt, moderate 30 kt, severe 45 kt.

Spectra with T = L/V (V the airspeed that turns the frozen spatial field into time):

* longitudinal ``H_u(s) = σ_u √(2T/π) / (1 + T s)`` — first-order Gauss-Markov,
  autocorrelation ``σ² e^{-τ/T}``;
* lateral/vertical ``H(s) = σ √(T/π) (1 + √3 T s) / (1 + T s)²``, autocorrelation
  ``σ² (1 - τ/(2T)) e^{-τ/T}``.

Each filter is discretised EXACTLY at the step dt (zero-order state transition
``Φ = e^{A dt}`` and process covariance ``Q = P - Φ P Φᵀ`` with P the stationary covariance),
so the output std equals σ at any dt, and the initial state is drawn from the stationary
distribution. The driving noise comes from a seeded numpy Generator in blocks; the state
advances by whole steps of simulated time (``advance_to(t)``), never per call, so values
are the same for a seed whatever the query pattern.
"""

from __future__ import annotations

import math

import numpy as np

from vinecli.frames import Vec3

FT = 0.3048
KT = 0.514444
#: mean wind at 20 ft (m/s) per MIL-F-8785C intensity
W20_MPS: dict[str, float] = {"light": 15 * KT, "moderate": 30 * KT, "severe": 45 * KT}

__all__ = ["DrydenTurbulence", "W20_MPS", "low_altitude_parameters"]


def low_altitude_parameters(altitude_m: float, w20_mps: float) -> tuple[Vec3, Vec3]:
    """((L_u, L_v, L_w) m, (σ_u, σ_v, σ_w) m/s) for a height above ground (m) and W20 (m/s)."""
    h = min(max(altitude_m / FT, 10.0), 1000.0)
    k = 0.177 + 0.000823 * h
    l_uv = h / k**1.2 * FT
    l_w = h * FT
    s_w = 0.1 * w20_mps
    s_uv = s_w / k**0.4
    return (l_uv, l_uv, l_w), (s_uv, s_uv, s_w)


def _second_order(T: float, dt: float) -> tuple[list[list[float]], list[list[float]], list[float], list[list[float]]]:
    """Exact discretisation of (1 + √3 T s)/(1 + T s)² with unit output variance.

    Returns (Φ, L_q, c, L_p): x' = Φ x + L_q n, y = c·x, x0 = L_p n0.
    """
    # closed form (no scipy import on a run's start-up): a has the double eigenvalue -1/T, so
    # exp(a dt) = e^(-dt/T) (I + (a + I/T) dt); the stationary covariance (a p + p aᵀ + b bᵀ = 0) is
    # diag(T³/4, T/4)
    a = np.array([[0.0, 1.0], [-1.0 / T**2, -2.0 / T]])
    c = np.array([1.0, math.sqrt(3.0) * T])
    p = np.diag([T**3 / 4.0, T / 4.0])
    c = c / math.sqrt(float(c @ p @ c))
    phi = math.exp(-dt / T) * (np.eye(2) + (a + np.eye(2) / T) * dt)
    q = p - phi @ p @ phi.T
    q = 0.5 * (q + q.T) + np.eye(2) * 1e-300
    lq = np.linalg.cholesky(q)
    lp = np.linalg.cholesky(p)
    return phi.tolist(), lq.tolist(), c.tolist(), lp.tolist()


class DrydenTurbulence:
    """Three turbulence components (u along the mean wind, v lateral, w vertical), m/s.

    ``sigma`` and ``length`` are (u, v, w); ``airspeed`` m/s; ``dt`` the filter step (s).
    """

    BLOCK = 2048

    def __init__(self, sigma: Vec3, length: Vec3, airspeed: float, dt: float, rng: np.random.Generator) -> None:
        if dt <= 0 or airspeed <= 0:
            raise ValueError("dt and airspeed must be positive")
        self.sigma = tuple(float(s) for s in sigma)
        self.length = tuple(float(v) for v in length)
        self.airspeed = float(airspeed)
        self.dt = float(dt)
        self.inv_dt = 1.0 / self.dt
        self._rng = rng
        t_u, t_v, t_w = (L / self.airspeed for L in self.length)
        self.time_constants: Vec3 = (t_u, t_v, t_w)
        self._a_u = math.exp(-dt / t_u)
        self._q_u = math.sqrt(max(0.0, 1.0 - self._a_u * self._a_u))
        self._v = _second_order(t_v, dt)
        self._w = _second_order(t_w, dt)
        self._buf: list[float] = []
        self._i = 0
        n0 = self._normals(5)
        lv, lw = self._v[3], self._w[3]
        self._xu = n0[0]
        self._xv0, self._xv1 = lv[0][0] * n0[1], lv[1][0] * n0[1] + lv[1][1] * n0[2]
        self._xw0, self._xw1 = lw[0][0] * n0[3], lw[1][0] * n0[3] + lw[1][1] * n0[4]
        su, sv, sw = self.sigma

        def flat(m: tuple, s_out: float) -> tuple[float, ...]:
            (p00, p01), (p10, p11) = m[0]
            (l00, _), (l10, l11) = m[1]
            c0, c1 = m[2]
            return (p00, p01, p10, p11, l00, l10, l11, s_out * c0, s_out * c1)

        self._kv = flat(self._v, sv)
        self._kw = flat(self._w, sw)
        self._su = su
        self.k = 0  # current step index: state is the value at t = k dt
        self._out = self._output()

    def _normals(self, n: int) -> list[float]:
        if self._i + n > len(self._buf):
            self._buf = self._rng.standard_normal(self.BLOCK * 5).tolist()
            self._i = 0
        i = self._i
        self._i = i + n
        return self._buf[i : i + n]

    def _output(self) -> Vec3:
        kv, kw = self._kv, self._kw
        return (
            self._su * self._xu,
            kv[7] * self._xv0 + kv[8] * self._xv1,
            kw[7] * self._xw0 + kw[8] * self._xw1,
        )

    def step(self) -> Vec3:
        """Advance one step dt; returns the new (u, v, w)."""
        if self._i + 5 > len(self._buf):
            self._buf = self._rng.standard_normal(self.BLOCK * 5).tolist()
            self._i = 0
        b, i = self._buf, self._i
        self._i = i + 5
        xu = self._a_u * self._xu + self._q_u * b[i]
        p00, p01, p10, p11, l00, l10, l11, cv0, cv1 = self._kv
        x0, x1, n1 = self._xv0, self._xv1, b[i + 1]
        v0 = p00 * x0 + p01 * x1 + l00 * n1
        v1 = p10 * x0 + p11 * x1 + l10 * n1 + l11 * b[i + 2]
        p00, p01, p10, p11, l00, l10, l11, cw0, cw1 = self._kw
        x0, x1, n1 = self._xw0, self._xw1, b[i + 3]
        w0 = p00 * x0 + p01 * x1 + l00 * n1
        w1 = p10 * x0 + p11 * x1 + l10 * n1 + l11 * b[i + 4]
        self._xu, self._xv0, self._xv1, self._xw0, self._xw1 = xu, v0, v1, w0, w1
        self.k += 1
        out = (self._su * xu, cv0 * v0 + cv1 * v1, cw0 * w0 + cw1 * w1)
        self._out = out
        return out

    def advance_to(self, t: float) -> Vec3:
        """Value at time t (s): the state after floor(t/dt) steps (zero-order hold; never goes back)."""
        n = int(t * self.inv_dt + 1e-9)
        while self.k < n:
            self.step()
        return self._out

    @property
    def value(self) -> Vec3:
        """Current (u, v, w), m/s."""
        return self._out
