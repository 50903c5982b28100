"""Scalar PID controller with anti-windup and a low-pass filtered derivative.

Units are whatever the caller uses (error in, command out); time in seconds. The derivative
acts on the measurement (no derivative kick on setpoint steps) and is filtered by a
first-order low-pass with cut-off ``d_cutoff_hz``. Anti-windup:

* **clamping** (conditional integration): the integral is frozen while the output is
  saturated and the error would push it further into saturation; the integral itself is
  also clamped to ``[-i_limit, i_limit]``;
* **back-calculation** (optional, ``k_aw > 0``): the integral is additionally driven by
  ``k_aw * (u_sat - u_unsat)``, bleeding it off while saturated.

Plain floats only: this runs in the 250 Hz loop.
"""

from __future__ import annotations

import math


class Pid:
    """``u = kp e + i + kd d(-meas)/dt`` saturated to ``[out_min, out_max]``.

    ``update(error, measurement, dt)`` returns the saturated output. ``external_sat``
    (-1/0/+1) lets a downstream stage (e.g. the mixer) report saturation so the integral
    stops growing in that direction (PX4 rate-controller style).
    """

    __slots__ = ("kp", "ki", "kd", "i_limit", "out_min", "out_max", "k_aw", "d_alpha_tau", "integral",
                 "_d_filt", "_prev_meas", "last_unsat", "last_out")

    def __init__(
        self,
        kp: float,
        ki: float = 0.0,
        kd: float = 0.0,
        *,
        i_limit: float = math.inf,
        out_min: float = -math.inf,
        out_max: float = math.inf,
        d_cutoff_hz: float = 30.0,
        k_aw: float = 0.0,
    ) -> None:
        self.kp = float(kp)
        self.ki = float(ki)
        self.kd = float(kd)
        self.i_limit = float(i_limit)
        self.out_min = float(out_min)
        self.out_max = float(out_max)
        self.k_aw = float(k_aw)
        self.d_alpha_tau = 1.0 / (2.0 * math.pi * d_cutoff_hz) if d_cutoff_hz > 0 else 0.0
        self.integral = 0.0
        self._d_filt = 0.0
        self._prev_meas: float | None = None
        self.last_unsat = 0.0
        self.last_out = 0.0

    def reset(self, integral: float = 0.0) -> None:
        """Clear the derivative history and set the integral (command units)."""
        self.integral = integral
        self._d_filt = 0.0
        self._prev_meas = None

    def update(self, error: float, measurement: float, dt: float, external_sat: int = 0) -> float:
        """One step: ``error`` = setpoint - measurement; returns the saturated command."""
        u_sat = self.output(error, measurement, dt)
        self.integrate(error, dt, external_sat)
        return u_sat

    def output(self, error: float, measurement: float, dt: float) -> float:
        """The saturated command for this step, without integrating (call :meth:`integrate` next).

        Split from :meth:`update` for a caller that learns of downstream saturation (``external_sat``)
        only after using the command, as the cascade's rate loop does with the mixer.
        """
        # filtered derivative of the measurement
        d = 0.0
        if self.kd != 0.0:
            prev = self._prev_meas
            if prev is not None and dt > 0.0:
                raw = (prev - measurement) * (1.0 / dt)
                a = dt / (self.d_alpha_tau + dt)
                self._d_filt += a * (raw - self._d_filt)
            d = self.kd * self._d_filt
        self._prev_meas = measurement
        u = self.kp * error + self.integral + d
        lo, hi = self.out_min, self.out_max
        u_sat = hi if u > hi else (lo if u < lo else u)
        self.last_unsat = u
        self.last_out = u_sat
        return u_sat

    def integrate(self, error: float, dt: float, external_sat: int = 0) -> None:
        """Advance the integral after :meth:`output`: conditional integration + optional back-calculation."""
        u, u_sat = self.last_unsat, self.last_out
        if self.ki != 0.0:
            di = self.ki * error * dt
            sat_dir = 1 if u > self.out_max else (-1 if u < self.out_min else external_sat)
            if not ((sat_dir > 0 and di > 0.0) or (sat_dir < 0 and di < 0.0)):
                self.integral += di
        if self.k_aw != 0.0:
            self.integral += self.k_aw * (u_sat - u) * dt
        il = self.i_limit
        if self.integral > il:
            self.integral = il
        elif self.integral < -il:
            self.integral = -il
