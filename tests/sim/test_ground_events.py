"""The simulator's truth events (vinecli.sim.ground_events) and the spray groups handed to the transport
model (vinecli.sim.spray_groups), step by step without PyBullet."""

from __future__ import annotations

import math

import pytest

from vinecli.sim.ground_events import GroundEvents
from vinecli.sim.spray_groups import SprayGroups
from vinecli.types import Event

DT_US = 4000  # 250 Hz


def detector(airborne: bool = False, crash_mps: float = 3.0) -> tuple[GroundEvents, list[Event], dict[str, float]]:
    events: list[Event] = []
    metrics = {"liftoff_s": math.nan, "touchdown_s": math.nan, "max_impact_speed_mps": 0.0}
    return GroundEvents(12, airborne, crash_mps, events, metrics), events, metrics


def fly(ground: GroundEvents, contact: list[bool], vz: float = -0.5, lifting: bool = True, k0: int = 0) -> bool:
    crashed = False
    for k, on in enumerate(contact):
        crashed |= ground.update(on, (k0 + k) * DT_US, vz, 1.0, lifting)
    return crashed


def test_liftoff_and_touchdown_after_the_debounce_at_the_first_changed_step() -> None:
    ground, events, metrics = detector()
    fly(ground, [True] * 5 + [False] * 11)  # 11 steps off the ground: not yet
    assert events == [] and not ground.airborne
    fly(ground, [False] * 3, k0=16)
    assert [e.kind for e in events] == ["liftoff"] and events[0].t_us == 5 * DT_US
    assert metrics["liftoff_s"] == pytest.approx(0.02)
    fly(ground, [True] * 12, vz=-0.8, k0=100)
    assert [e.kind for e in events] == ["liftoff", "touchdown"] and metrics["touchdown_s"] == pytest.approx(0.4)
    assert metrics["max_impact_speed_mps"] == pytest.approx(0.8)


def test_a_bounce_without_thrust_is_no_liftoff_and_a_hard_impact_is_a_crash() -> None:
    ground, events, _metrics = detector()
    assert not fly(ground, [False] * 20, lifting=False)  # off the ground, rotors idle: a bounce or a tumble
    assert events == [] and not ground.airborne
    ground, events, metrics = detector(airborne=True)
    assert not fly(ground, [False] * 5)
    assert fly(ground, [True], vz=-4.5, k0=5)  # the first contact is an impact: 4.5 m/s > 3 m/s
    assert [e.kind for e in events] == ["crash"] and ground.impact_mps == pytest.approx(4.5)
    assert metrics["max_impact_speed_mps"] == pytest.approx(4.5)


def test_spray_groups_sum_the_volume_and_end_when_the_flow_stops() -> None:
    got: list[tuple[float, ...]] = []
    groups = SprayGroups(got.append, 10, 0.004)
    state = ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0), (2.0, 0.0, 0.0), (0.5, 0.0, 0.0), 30.0)
    for k in range(25):
        groups.add(0.02 if k < 23 else 0.0, k * 0.004, *state)
    assert len(got) == 3  # 10 + 10 steps, then the 3 left when the flow stopped
    assert [g[15] for g in got] == pytest.approx([0.02 * 0.004 * n for n in (10, 10, 3)])
    assert [g[16] for g in got] == pytest.approx([0.5 * 9 * 0.004, 0.5 * 9 * 0.004, 0.5 * 2 * 0.004])
    assert got[2][0] == pytest.approx(23 * 0.004) and got[0][1:4] == (1.0, 2.0, 3.0) and got[0][14] == 30.0
    groups.add(0.02, 1.0, *state)
    groups.flush()  # the run ends while spraying: the open group goes out
    assert len(got) == 4 and got[3][15] == pytest.approx(0.02 * 0.004) and got[3][16] == 0.0
