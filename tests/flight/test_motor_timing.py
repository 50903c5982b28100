"""Motor lag timing: speeds at the step's time, forces from the exact interval means.

The rigid-body step holds a force constant over [t_k, t_k + dt]; with the lagged speed
w(s) = c + (w_k - c) e^(-s/tau) the exact impulse of rotor i is k_f ∫ w² ds. Using the end-of-step
speed instead makes the effective lag tau - dt/2 (a 1 % fast roll step at 4 ms / 12.5 ms).
"""

from __future__ import annotations

import math

import pytest

from vinecli.flight.motor import MotorBank
from vinecli.specs.vehicle import MotorSpec, RotorSpec

TAU_UP, TAU_DOWN = 0.0125, 0.025
K_F = 8.54858e-6


def _bank() -> MotorBank:
    m = MotorSpec(k_f=K_F, k_m=0.016, k_d=0.0, k_roll=0.0, w_max=1200.0, tau_up_s=TAU_UP, tau_down_s=TAU_DOWN)
    return MotorBank(m, [RotorSpec(position_m=(0.1, 0.1, 0.0), spin="ccw")])


def _w(t: float, w0: float, c: float, tau: float) -> float:
    return c + (w0 - c) * math.exp(-t / tau)


def _int_w2(t: float, w0: float, c: float, tau: float) -> float:
    """∫_0^t w(s)² ds for the first-order lag (closed form)."""
    d = w0 - c
    return c * c * t + 2 * c * d * tau * (1 - math.exp(-t / tau)) + d * d * tau / 2 * (1 - math.exp(-2 * t / tau))


@pytest.mark.parametrize(("w0", "c", "tau"), [(100.0, 900.0, TAU_UP), (900.0, 300.0, TAU_DOWN)])
@pytest.mark.parametrize("dt", [0.004, 0.001])
def test_speed_at_step_time_and_impulse_match_the_analytic_lag(w0: float, c: float, tau: float, dt: float) -> None:
    bank = _bank()
    bank.reset(w0)
    impulse = end_speed_impulse = 0.0
    n = int(round(0.2 / dt))
    for k in range(n):
        bank.update([c], dt)
        t = k * dt
        # the speed shown for t_k is the speed at t_k (not at t_k + dt)
        assert bank.w_start[0] == pytest.approx(_w(t, w0, c, tau), rel=1e-9)
        bank.wrench(None)
        impulse += bank.thrust[0] * dt
        end_speed_impulse += K_F * bank.w[0] ** 2 * dt
    t_end = n * dt
    assert bank.w[0] == pytest.approx(_w(t_end, w0, c, tau), rel=1e-9)
    exact = K_F * _int_w2(t_end, w0, c, tau)
    # analytic within 0.1 % as the issue asks; it is exact to rounding
    assert impulse == pytest.approx(exact, rel=1e-9)
    # forces from the end-of-step speeds (lag tau - dt/2) miss it by more than the 0.1 % tolerance
    # at 250 Hz: the test can tell the two timings apart
    if dt == 0.004:
        assert abs(end_speed_impulse - exact) / exact > 1e-3


def test_per_rotor_reset_and_interval_means_at_steady_state() -> None:
    bank = _bank()
    bank.reset([500.0])
    bank.update([500.0], 0.004)
    assert bank.w_mean[0] == pytest.approx(500.0, rel=1e-12)
    assert bank.w2_mean[0] == pytest.approx(250000.0, rel=1e-12)
    with pytest.raises(ValueError, match="rotor speeds"):
        bank.reset([1.0, 2.0])
