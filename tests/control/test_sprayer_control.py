"""Speed-scaled flow as ArduPilot's AC_Sprayer (control/sprayer.py): flow = litres per metre x ground speed, on
only after the speed stayed >= SPRAY_SPEED_MIN for 100 ms, off after 1 s below, sections gate at once."""

from __future__ import annotations

import math

import pytest

from vinecli.control.sprayer import SpeedScaledSprayer
from vinecli.specs.sprayer import SprayControlSpec

DT = 0.02  # the position-loop rate


def run(s: SpeedScaledSprayer, seconds: float, speed: float, per_m: float = 0.01, open_: bool = True) -> list[float]:
    return [s.update(DT, speed, per_m, open_) for _ in range(int(round(seconds / DT)))]


def test_flow_follows_speed_above_the_minimum_after_the_on_delay() -> None:
    s = SpeedScaledSprayer(SprayControlSpec(), max_flow_lps=0.1)
    assert run(s, 1.0, 0.5) == [0.0] * 50  # below SPRAY_SPEED_MIN (1 m/s): never on
    flows = run(s, 0.2, 2.0)
    assert flows[:4] == [0.0] * 4 and flows[5] == pytest.approx(0.02)  # on after 0.1 s at >= 1 m/s
    assert run(s, 0.1, 3.0)[-1] == pytest.approx(0.03)  # litres per metre held: flow = 0.01 x speed
    assert run(s, 0.1, 20.0)[-1] == pytest.approx(0.1)  # at most the pump's maximum


def test_off_only_after_the_off_delay_below_the_minimum_speed() -> None:
    s = SpeedScaledSprayer(SprayControlSpec(), max_flow_lps=0.1)
    run(s, 1.0, 2.0)
    slow = run(s, 1.2, 0.5)
    assert slow[0] == pytest.approx(0.005) and slow[45] == pytest.approx(0.005)  # still spraying, scaled
    assert slow[-1] == 0.0 and not s.spraying  # off after 1 s below the minimum
    s = SpeedScaledSprayer(SprayControlSpec(), max_flow_lps=0.1)
    run(s, 1.0, 2.0)
    assert run(s, 1.2, math.nan)[-1] == 0.0  # velocity unknown counts as 0


def test_sections_gate_the_flow_at_once_and_the_timers_run_on() -> None:
    s = SpeedScaledSprayer(SprayControlSpec(), max_flow_lps=0.1)
    assert run(s, 1.0, 2.0, open_=False)[-1] == 0.0
    assert s.spraying  # the speed rule is met: opening a section at speed sprays at once
    assert s.update(DT, 2.0, 0.01, True) == pytest.approx(0.02)
