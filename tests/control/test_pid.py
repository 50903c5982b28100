"""PID: proportional/integral/derivative arithmetic, anti-windup by clamping and back-calculation."""

from __future__ import annotations

import math

import pytest

from vinecli.control.pid import Pid


def test_pid_terms_add_up() -> None:
    pid = Pid(2.0, 0.5, 0.0)
    u = pid.update(1.0, 0.0, 0.1)
    assert u == pytest.approx(2.0)  # integral is added after the output is formed
    assert pid.integral == pytest.approx(0.05)
    u = pid.update(1.0, 0.0, 0.1)
    assert u == pytest.approx(2.0 + 0.05)


def test_derivative_on_measurement_is_filtered_and_kick_free() -> None:
    pid = Pid(0.0, 0.0, 1.0, d_cutoff_hz=1e6)
    assert pid.update(5.0, 0.0, 0.01) == 0.0  # no derivative on the first sample, no setpoint kick
    # measurement rises 0.1 per 0.01 s -> d(-meas)/dt = -10
    assert pid.update(5.0, 0.1, 0.01) == pytest.approx(-10.0, rel=1e-3)
    slow = Pid(0.0, 0.0, 1.0, d_cutoff_hz=5.0)
    slow.update(0.0, 0.0, 0.01)
    first = slow.update(0.0, 0.1, 0.01)
    a = 0.01 / (1 / (2 * math.pi * 5.0) + 0.01)
    assert first == pytest.approx(-10.0 * a)  # first-order low-pass


def test_clamping_freezes_the_integral_while_saturated() -> None:
    pid = Pid(1.0, 1.0, out_min=-1.0, out_max=1.0)
    for _ in range(1000):  # large error for 10 s: output saturated
        pid.update(5.0, 0.0, 0.01)
    assert pid.last_out == 1.0
    assert pid.integral == pytest.approx(0.0)  # never integrated in the saturated direction
    # the error reverses: the output leaves saturation at once (no wound-up integral to unwind)
    u = pid.update(-0.5, 0.0, 0.01)
    assert u == pytest.approx(-0.5)
    assert pid.integral == pytest.approx(-0.005)


def test_without_anti_windup_the_integral_would_grow() -> None:
    # the same run with an unlimited output integrates the full error: 5 * 10 s
    pid = Pid(1.0, 1.0)
    for _ in range(1000):
        pid.update(5.0, 0.0, 0.01)
    assert pid.integral == pytest.approx(50.0)


def test_integral_limit_and_external_saturation() -> None:
    pid = Pid(0.0, 10.0, i_limit=0.3)
    for _ in range(100):
        pid.update(1.0, 0.0, 0.01)
    assert pid.integral == pytest.approx(0.3)
    ext = Pid(0.0, 1.0)
    ext.update(1.0, 0.0, 0.1, external_sat=1)  # downstream saturated upwards: no positive integration
    assert ext.integral == 0.0
    ext.update(-1.0, 0.0, 0.1, external_sat=1)  # unwinding direction still allowed
    assert ext.integral == pytest.approx(-0.1)


def test_back_calculation_bleeds_the_integral() -> None:
    pid = Pid(1.0, 0.0, out_max=1.0, k_aw=2.0)
    pid.integral = 3.0
    pid.update(0.0, 0.0, 0.1)  # u = 3 -> saturated at 1 -> integral += 2 * (1 - 3) * 0.1
    assert pid.integral == pytest.approx(2.6)
