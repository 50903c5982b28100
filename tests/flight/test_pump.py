"""Pump and valve (flight/pump.py): first-order lag discretised exactly, interval-mean delivery, clamps, duty input."""

from __future__ import annotations

import math

import pytest

from vinecli.flight.pump import Pump
from vinecli.specs.sprayer import PumpSpec

DT = 0.004


def test_step_response_is_the_exact_first_order_lag_and_the_tank_gets_its_integral() -> None:
    tau = 0.3
    p = Pump(PumpSpec(tau_up_s=tau, tau_down_s=0.15), 0.1)
    q, vol, t = 0.05, 0.0, 0.0
    for _ in range(250):  # 1 s
        vol += p.update(q, DT) * DT
        t += DT
        assert p.flow_lps == pytest.approx(q * (1.0 - math.exp(-t / tau)), rel=1e-9)
    # delivered volume = the integral of the lagged flow: q (t - tau (1 - e^-t/tau)), to rounding
    assert vol == pytest.approx(q * (t - tau * (1.0 - math.exp(-t / tau))), rel=1e-9)


def test_a_step_on_delivers_q_tau_less_and_a_step_off_q_tau_more() -> None:
    """What the section lead compensates: a switch-on is a step delayed by tau_up, a switch-off by tau_down."""
    p = Pump(PumpSpec(tau_up_s=0.3, tau_down_s=0.15), 0.1)
    q = 0.04
    on = sum(p.update(q, DT) * DT for _ in range(2500))  # 10 s on
    assert on == pytest.approx(q * (10.0 - 0.3), rel=1e-6)
    off = sum(p.update(0.0, DT) * DT for _ in range(2500))  # then off
    assert off == pytest.approx(q * 0.15, rel=1e-5)
    assert p.flow_lps == 0.0  # the exponential tail snaps to no flow


def test_commands_clamped_to_the_pump_and_duty_input() -> None:
    p = Pump(PumpSpec(tau_up_s=0.0, tau_down_s=0.0), 0.1)  # no lag
    assert p.update(0.5, DT) == pytest.approx(0.1) and p.flow_cmd_lps == 0.1
    assert p.update(-1.0, DT) == 0.0
    assert p.update(math.nan, DT) == 0.0
    assert p.update_duty(0.25, DT) == pytest.approx(0.025)
    assert p.update_duty(2.0, DT) == pytest.approx(0.1)
    assert p.update_duty(math.nan, DT) == 0.0
