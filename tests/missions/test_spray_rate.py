"""Application rate <-> flow with the track width (missions/spray_rate.py)."""

from __future__ import annotations

import pytest

from vinecli.rows.spray_rate import (
    flow_for_rate,
    nominal_rate_lpha,
    phase_rows,
    resolve_spray_rates,
    spray_swath_m,
    track_width_m,
)
from vinecli.specs.mission import MissionSpec, SprayPhase
from vinecli.vehicle import load_vehicle


def _rows(spacing: float, n: int = 4) -> list[list[tuple[float, float]]]:
    return [[(i * spacing, 0.0), (i * spacing, 30.0)] for i in range(n)]


def test_track_width_is_the_swath_or_the_closer_row_spacing() -> None:
    v = load_vehicle("x500-sprayer")
    ph = SprayPhase(rows="world", height_agl_m=2.0, speed_mps=3.0, rate_lpha=100.0)
    swath = spray_swath_m(v, 2.0)
    assert 2.0 < swath < 6.0
    assert track_width_m(v, ph, _rows(0.9)) == pytest.approx(0.9)        # every row of a potato field
    assert track_width_m(v, ph, _rows(swath + 1.0)) == pytest.approx(swath)  # rows wider apart than the swath
    assert track_width_m(v, ph, _rows(0.9, n=1)) == pytest.approx(swath)   # one row: the swath


def test_rate_resolves_to_the_flow_of_the_track_width_and_back() -> None:
    v = load_vehicle("x500-sprayer")
    m = MissionSpec.model_validate({"name": "r", "phases": [
        {"type": "takeoff", "altitude_agl_m": 3.0},
        {"type": "spray", "rows": [0, 1, 2], "height_agl_m": 2.0, "speed_mps": 3.0, "rate_lpha": 100.0}]})
    world_rows = _rows(0.9, n=6)
    r = resolve_spray_rates(m, v, world_rows)
    ph = r.phases[1]
    assert ph.flow_lps == pytest.approx(flow_for_rate(100.0, 0.9, 3.0)) == pytest.approx(0.027)
    flow_only = ph.model_copy(update={"rate_lpha": None})
    assert nominal_rate_lpha(flow_only, v, phase_rows(flow_only, world_rows)) == pytest.approx(100.0)
    assert len(phase_rows(ph, world_rows)) == 3
