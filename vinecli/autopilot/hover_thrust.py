"""Hover thrust estimated in flight, as PX4's ``mc_hover_thrust_estimator`` (v1.15) does it.

A one-state Kalman filter (``ZeroOrderHoverThrustEkf``) on the hover thrust ``Th`` (collective
thrust normalised to the maximum thrust, at which the vehicle hovers): the state is constant with
process noise ``HTE_HT_NOISE``; the measurement is the estimated vertical acceleration ``a_z`` (ENU
up, gravity removed) against the model ``a_z = g T / Th - g`` with ``T`` the vertical component of
the thrust setpoint. The measurement noise is learnt from the residuals (``R``, time constant 2 s);
a measurement whose normalised innovation exceeds the ``HTE_ACC_GATE`` gate is rejected, and when
rejections persist (low-passed signed test ratio beyond 0.2) the state variance is bumped so that
a sudden change (a payload dropped, the tank refilled) is re-learnt. Fast vertical (above
``HTE_VZ_THR``) or horizontal (above ``HTE_VXY_THR``) motion scales the noise up.

The filter runs while armed and in the air (set once the distance to the ground exceeds 1 m,
cleared when landed); disarmed it restarts from the nominal hover thrust (``MPC_THR_HOVER``: the
vehicle spec's empty mass plus payload) with ``HTE_HT_ERR_INIT`` uncertainty. The estimate is
``valid`` after its variance stayed below 1e-3 (and the first time, the test ratio below 1) for 2 s.
With a thrust-linear mixer the hover thrust is ``m g / T_max``: the estimated mass is
``Th T_max / g``.
"""

from __future__ import annotations

from typing import ClassVar

from vinecli.autopilot.land_detector import Hysteresis
from vinecli.constants import STANDARD_GRAVITY

G = STANDARD_GRAVITY


def _clamp(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else (hi if x > hi else x)


class HoverThrustEkf:
    """PX4 ``ZeroOrderHoverThrustEkf``: state ``hover_thr`` (normalised), variance ``state_var``."""

    NOISE_LEARNING_TAU: ClassVar[float] = 2.0  # s
    LPF_TAU: ClassVar[float] = 1.0  # s

    def __init__(self, hover_thr: float, *, hover_thr_min: float = 0.1, hover_thr_max: float = 0.9,
                 process_noise: float = 0.0036, hover_thr_sigma: float = 0.1, gate: float = 3.0) -> None:
        self.hover_thr_min = hover_thr_min
        self.hover_thr_max = hover_thr_max
        self.process_var = process_noise * process_noise  # (thrust/s)²
        self.gate = gate
        self.hover_thr = 0.5
        self.state_var = 0.01
        self.acc_var = 5.0  # (m/s²)², learnt
        self.reset(hover_thr, hover_thr_sigma)
        self.acc_var_scale = 1.0
        self.dt = 0.02
        self.innov = 0.0
        self.innov_var = 0.0
        self.innov_test_ratio = 0.0
        self.residual_lpf = 0.0
        self.signed_innov_test_ratio_lpf = 0.0

    def reset(self, hover_thr: float, hover_thr_sigma: float) -> None:
        """Restart at ``hover_thr`` with 1-σ uncertainty ``hover_thr_sigma`` and the initial measurement noise."""
        self.hover_thr = _clamp(hover_thr, 0.1, 0.9)
        self.state_var = hover_thr_sigma * hover_thr_sigma
        self.acc_var = 5.0

    def predict(self, dt: float) -> None:
        """The state is constant: only its variance grows."""
        self.state_var += self.process_var * dt * dt
        self.dt = dt

    def fuse_acc_z(self, acc_z: float, thrust: float) -> None:
        """Fuse one vertical acceleration (m/s², up) measured with vertical thrust setpoint ``thrust``."""
        h = -G * thrust / (self.hover_thr * self.hover_thr)
        r = self.acc_var * self.acc_var_scale
        hph = h * self.state_var * h
        innov_var = hph + r if hph > 0.0 else r
        innov = acc_z - (G * thrust / self.hover_thr - G)
        k = self.state_var * h / innov_var
        test_ratio = innov * innov / (self.gate * self.gate * innov_var)
        residual = innov
        if test_ratio < 1.0:
            self.hover_thr = _clamp(self.hover_thr + k * innov, self.hover_thr_min, self.hover_thr_max)
            self.state_var = _clamp((1.0 - k * h) * self.state_var, 1e-10, 1.0)
            residual = acc_z - (G * thrust / self.hover_thr - G)  # the hover thrust changed
        elif abs(self.signed_innov_test_ratio_lpf) > 0.2:
            self.state_var += 1e3 * self.process_var * self.dt  # rejected for a while: re-learn
        signed = test_ratio if innov >= 0.0 else -test_ratio
        a = self.dt / (self.LPF_TAU + self.dt)
        self.residual_lpf = (1.0 - a) * self.residual_lpf + a * residual
        self.signed_innov_test_ratio_lpf = (1.0 - a) * self.signed_innov_test_ratio_lpf + a * _clamp(signed, -1.0, 1.0)
        a = self.dt / (self.NOISE_LEARNING_TAU + self.dt)
        res = residual - self.residual_lpf
        self.acc_var = _clamp((1.0 - a) * self.acc_var + a * (res * res + h * self.state_var * h), 1.0, 400.0)
        self.innov, self.innov_var, self.innov_test_ratio = innov, innov_var, test_ratio


class HoverThrustEstimator:
    """PX4's hover thrust estimator module around :class:`HoverThrustEkf` (see the module docstring).

    ``hover_thrust`` is the current estimate (normalised), ``valid`` whether the autopilot may use it."""

    VALID_US: ClassVar[int] = 2_000_000
    IN_AIR_DIST_M: ClassVar[float] = 1.0

    def __init__(self, hover_thrust_param: float, *, thr_range: float = 0.2, process_noise: float = 0.0036,
                 err_init: float = 0.1, gate: float = 3.0, vz_thr: float = 2.0, vxy_thr: float = 10.0) -> None:
        self.param = hover_thrust_param  # MPC_THR_HOVER
        self.thr_min = _clamp(hover_thrust_param - thr_range, 0.0, 0.8)  # HTE_THR_RANGE
        self.thr_max = _clamp(hover_thrust_param + thr_range, 0.2, 0.9)
        self.err_init = err_init  # HTE_HT_ERR_INIT
        self.vz_thr = vz_thr  # HTE_VZ_THR, m/s
        self.vxy_thr = vxy_thr  # HTE_VXY_THR, m/s
        self.in_air = False
        self.valid = False
        self._valid_h = Hysteresis(False, self.VALID_US)
        self._t_last_us: int | None = None
        self.ekf = HoverThrustEkf(hover_thrust_param, hover_thr_min=self.thr_min, hover_thr_max=self.thr_max,
                                  process_noise=process_noise, hover_thr_sigma=err_init, gate=gate)

    @property
    def hover_thrust(self) -> float:
        """The estimated hover thrust, normalised to the maximum thrust."""
        return self.ekf.hover_thr

    @property
    def hover_thrust_var(self) -> float:
        return self.ekf.state_var

    def update(self, t_us: int, armed: bool, landed: bool, dist_bottom: float, vz: float, vxy: float,
               acc_z: float, thrust_z: float) -> None:
        """One position-loop update at ``t_us``: ``dist_bottom`` height above the ground (m, NaN when
        unknown), ``vz``/``vxy`` estimated vertical / horizontal speed (m/s), ``acc_z`` estimated
        vertical acceleration (m/s², up), ``thrust_z`` vertical thrust setpoint (normalised, up)."""
        if landed:
            self.in_air = False
        elif dist_bottom > self.IN_AIR_DIST_M:
            self.in_air = True
        last = self._t_last_us
        self._t_last_us = t_us
        dt = (t_us - last) * 1e-6 if last is not None else 0.0
        if armed and self.in_air and 0.001 < dt < 1.0:
            ekf = self.ekf
            ekf.predict(dt)
            cz = abs(vz) - self.vz_thr + 1.0
            cxy = vxy - self.vxy_thr + 1.0
            scale = max(cz, cxy, 1.0)
            ekf.acc_var_scale = scale * scale
            ekf.fuse_acc_z(acc_z, thrust_z)
            ok = ekf.state_var < 0.001
            if not self.valid:
                ok = ok and ekf.innov_test_ratio < 1.0
            self._valid_h.set_state_and_update(ok, t_us)
            self.valid = self._valid_h.state
        else:
            self._valid_h.set_state_and_update(False, t_us)
            if not armed:  # restart from MPC_THR_HOVER
                self.ekf.reset(self.param, self.err_init)
            self.valid = False
