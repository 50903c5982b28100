"""Waypoints of a pass flown at segment rates (phase_items/spray_legs): a firmware slows down at short legs, so a
flow change must not sit a metre from a terrain-following waypoint (measured with PX4 v1.15 on the sample
vineyard's three-zone map: legs of 0.87-2.2 m at the changes, 0.7-0.9 m/s over them at its fixed flow, the 14 L/ha
zone +12.7 %)."""

from __future__ import annotations

import math

import pytest

from vinecli.phase_items.spray_legs import MIN_LEG_M, leg_actions
from vinecli.rows.plan import Leg


def _surface(x: float, y: float) -> float:
    return 0.02 * y + 0.3 * math.sin(y / 3.0)  # a gentle slope with canopy waves: every knot bends


def _legs(cuts: list[float], length: float = 64.0) -> list[Leg]:
    ends = [0.0, *cuts, length]
    return [Leg([(0.0, a), (0.0, b)], True, 0) for a, b in zip(ends[:-1], ends[1:], strict=True)]


def _flown(cuts: list[float], flows: list[float]) -> tuple[list[float], list[tuple[float, float]]]:
    """(waypoint distances along the pass, (distance, flow) where each flow starts)."""
    acts = leg_actions(_legs(cuts), height_m=2.0, flow_lps=0.0, surface=_surface, leg_flows=flows)
    ys, switches = [], []
    for a in acts:
        if a[0] == "wp":
            ys.append(a[2])
        elif a[0] == "spray":
            switches.append((ys[-1], a[1]))
    return ys, switches


@pytest.mark.parametrize("cuts", [[18.0, 44.3], [12.5, 19.0, 50.1], [6.0, 57.5]])
def test_no_short_leg_at_a_flow_change(cuts: list[float]) -> None:
    flows = [0.01 * (k + 1) for k in range(len(cuts) + 1)]
    ys, switches = _flown(cuts, flows)
    legs = [b - a for a, b in zip(ys[:-1], ys[1:], strict=True)]
    assert min(legs) >= MIN_LEG_M - 1e-6, legs
    assert [round(y, 6) for y, _ in switches[1:-1]] == cuts  # each flow starts where its leg starts
    assert [f for _, f in switches] == [*flows, 0.0]


def test_change_waypoint_on_the_profile_without_terrain() -> None:
    acts = leg_actions(_legs([18.0]), height_m=2.0, flow_lps=0.0, leg_flows=[0.01, 0.02])
    assert [(a[0], a[2] if a[0] == "wp" else a[1]) for a in acts] == [
        ("wp", 0.0), ("spray", 0.01), ("wp", 18.0), ("spray", 0.02), ("wp", 64.0), ("spray", 0.0)]


def _turn_then_pass(run_in: float) -> list[Leg]:
    """A pass north along x = 0, a stop turn (run-out, cross, run-in of ``run_in`` m), a pass south along x = 4
    with a 2 m gap in it."""
    return [Leg([(0.0, 0.0), (0.0, 20.0)], True, 0),
            Leg([(0.0, 20.0), (0.0, 20.0 + run_in), (4.0, 20.0 + run_in), (4.0, 20.0)], False, None, "turn-stop"),
            Leg([(4.0, 20.0), (4.0, 12.0)], True, 1), Leg([(4.0, 12.0), (4.0, 10.0)], False, None, "gap"),
            Leg([(4.0, 10.0), (4.0, 0.0)], True, 1)]


@pytest.mark.parametrize("flows", [None, [0.01, 0.0, 0.01, 0.0, 0.01]])
def test_speed_gated_sprayer_goes_on_at_the_run_in(flows: list[float] | None) -> None:
    """ArduPilot's AC_Sprayer sprays only above SPRAY_SPEED_MIN: switched on at the run-in point (measured: a
    waypoint at the pass start 0.85 m after it held ArduCopter at 0.45-0.6 m/s, the first 2 m of the row at 0.7x);
    not at a gap's start (the sections stay closed over the gap) nor from a run-in longer than the plan's."""
    kw = {"height_m": 2.0, "flow_lps": 0.01, "leg_flows": flows}
    plain = [(a[0], a[1:3] if a[0] == "wp" else a[1]) for a in leg_actions(_turn_then_pass(1.2), **kw)]
    acts = [(a[0], a[1:3] if a[0] == "wp" else a[1]) for a in leg_actions(_turn_then_pass(1.2), open_at_run_in=1.5, **kw)]
    i = plain.index(("wp", (4.0, 21.2)))
    assert plain[i + 1:i + 3] == [("wp", (4.0, 20.0)), ("spray", 0.01)]
    assert acts[i + 1] == ("spray", 0.01) and ("wp", (4.0, 20.0)) not in acts  # on at the run-in point
    assert acts[:i + 1] == plain[:i + 1] and acts[i + 2:] == plain[i + 3:]  # the gap's switches unchanged
    assert ("wp", (4.0, 10.0)) in acts and acts[acts.index(("wp", (4.0, 10.0))) + 1] == ("spray", 0.01)
    far = leg_actions(_turn_then_pass(2.0), open_at_run_in=1.5, **kw)
    assert ("wp", 4.0, 20.0, 2.0) in far  # a run-in longer than the plan's: the pass start stays
