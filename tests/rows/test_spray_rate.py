"""Spray phases against the sprayer (rows/spray_rate.py): the flow of the asked rate from the plan's track width
(effective swath, not the cone), and rates or speeds the sprayer cannot deliver refused with the numbers."""

from __future__ import annotations

import pytest

from vinecli.errors import InputError
from vinecli.rows.spray_rate import (
    flow_for_rate,
    nominal_rate_lpha,
    phase_plan,
    phase_rows,
    resolve_spray_rates,
    spray_pattern,
    spray_swath_m,
)
from vinecli.specs.mission import MissionSpec, SprayPhase
from vinecli.vehicle import load_vehicle


def _rows(spacing: float, n: int = 4) -> list[list[tuple[float, float]]]:
    return [[(i * spacing, 0.0), (i * spacing, 30.0)] for i in range(n)]


def _mission(**spray: object) -> MissionSpec:
    return MissionSpec.model_validate({"name": "r", "phases": [
        {"type": "takeoff", "altitude_agl_m": 3.0},
        {"type": "spray", "rows": [0, 1, 2], "height_agl_m": 2.0, "speed_mps": 3.0, "rate_lpha": 100.0, **spray}]})


def test_track_width_is_the_lane_spacing_or_the_single_pass_width_not_the_cone() -> None:
    v = load_vehicle("x500-sprayer")
    ph = SprayPhase(rows="world", height_agl_m=2.0, speed_mps=3.0, rate_lpha=100.0)
    swath = spray_swath_m(v, 2.0)
    pat = spray_pattern(v, 2.0, 3.0)
    # the effective swath is far narrower than the cones edge to edge: the wake carries the drops down as a plume
    # ~1 m wide (spray/wake.py)
    assert 0.5 < pat.effective_m < 0.5 * swath
    close = phase_plan(ph, v, _rows(0.3, 16), (0.0, -1.0))  # seed beds 0.3 m apart: passes every ~3 rows
    assert close.layout is not None and close.layout.mode == "broadcast"
    assert close.flow_width_m <= pat.effective_m and pat.good(close.flow_width_m)
    assert len(close.order) < 16
    one = phase_plan(ph, v, _rows(0.3, n=1), (0.0, -1.0))
    # doses the row's canopy band as flown (with the track error the layout counts: rows/lanes.py)
    assert one.flow_width_m == pytest.approx(pat.single_pass_width_m(0.6), rel=0.05)
    wide = phase_plan(ph, v, _rows(pat.effective_m + 1.0), (0.0, -1.0))  # a pass over each row
    assert wide.layout is not None and wide.layout.mode == "rows" and len(wide.order) == 4


def test_rate_resolves_to_the_flow_of_the_plan_and_back() -> None:
    v = load_vehicle("x500-sprayer")
    world_rows = _rows(0.9, n=6)
    r = resolve_spray_rates(_mission(), v, world_rows)
    ph = r.phases[1]
    assert isinstance(ph, SprayPhase)
    plan = phase_plan(ph, v, phase_rows(ph, world_rows), (0.0, 0.0))
    assert ph.flow_lps == pytest.approx(flow_for_rate(100.0, plan.flow_width_m, 3.0))
    assert ph.canopy_width_m == 0.6  # resolved (the world's)
    flow_only = ph.model_copy(update={"rate_lpha": None})
    assert nominal_rate_lpha(flow_only, v, plan) == pytest.approx(100.0)
    assert len(phase_rows(ph, world_rows)) == 3


def test_a_rate_the_pump_cannot_deliver_is_refused_with_the_numbers_or_flown_slower() -> None:
    v = load_vehicle("x500-sprayer")  # 0.1 L/s at most
    rows = _rows(0.9, n=6)
    plan = phase_plan(SprayPhase.model_validate(_mission(speed_mps=5.0, rate_lpha=300.0).phases[1].model_dump()), v,
                      phase_rows(_mission().phases[1], rows), (0.0, 0.0))
    need = flow_for_rate(300.0, plan.flow_width_m, 5.0)
    assert need > 0.1  # the plan's track width asks more than the pump gives at 5 m/s
    with pytest.raises(InputError, match=rf"300 L/ha over a {plan.flow_width_m:.2f} m track at 5 m/s needs "
                                         rf"{need:.4f} L/s; x500-sprayer's sprayer delivers at most 0\.1000 L/s: "
                                         r"fly at most [0-9.]+ m/s"):
        resolve_spray_rates(_mission(speed_mps=5.0, rate_lpha=300.0), v, rows)
    slow = resolve_spray_rates(_mission(speed_mps=5.0, rate_lpha=300.0, allow_slower=True), v, rows).phases[1]
    assert isinstance(slow, SprayPhase)
    assert 2.0 < slow.speed_mps < 5.0 and slow.flow_lps == pytest.approx(0.1)
    plan = phase_plan(slow, v, phase_rows(slow, rows), (0.0, 0.0))
    assert flow_for_rate(300.0, plan.flow_width_m, slow.speed_mps) == pytest.approx(0.1, rel=0.01)
    with pytest.raises(InputError, match="below the sprayer's minimum 1 m/s"):
        resolve_spray_rates(_mission(speed_mps=0.5), v, rows)


def test_nozzles_outside_their_pressure_range_are_refused() -> None:
    base = load_vehicle("x500-sprayer")
    sp = base.sprayer.model_copy(update={"rated_flow_lps": 0.05, "rated_pressure_bar": 3.0,
                                         "pressure_range_bar": (1.5, 8.0)})
    v = base.model_copy(update={"sprayer": sp})
    assert sp.flow_range_lps(0.1) == pytest.approx((0.05 * (0.5 ** 0.5), 0.05 * (8.0 / 3.0) ** 0.5))
    with pytest.raises(InputError, match="nozzles need at least 0.0354 L/s"):
        resolve_spray_rates(_mission(rate_lpha=20.0, speed_mps=2.0), v, _rows(0.9, n=6))


def test_rows_that_cannot_be_sprayed_are_refused_with_a_clear_line() -> None:
    v = load_vehicle("x500-sprayer")
    point = MissionSpec.model_validate({"name": "r", "phases": [
        {"type": "takeoff", "altitude_agl_m": 3.0},
        {"type": "spray", "rows": [[[1.0, 1.0], [1.0, 1.0]]], "height_agl_m": 2.0, "speed_mps": 3.0, "rate_lpha": 50.0}]})
    with pytest.raises(InputError, match=r"phases\.1 \(spray\): target row 0 is 0 m long"):
        resolve_spray_rates(point, v, [])
    far = [(500.0, 0.0), (500.0, 30.0)]  # a row entirely outside the fence: no pass to fly
    fence = [(-10.0, -10.0), (40.0, -10.0), (40.0, 40.0), (-10.0, 40.0)]
    with pytest.raises(InputError, match=r"phases\.1 \(spray\): no row left to spray inside the geofence"):
        resolve_spray_rates(_mission(rows=[0]), v, [far], fence_enu=fence)


def test_a_spray_speed_above_the_vehicles_top_speed_is_refused_or_flown_at_it() -> None:
    v = load_vehicle("x500-sprayer")  # control.max_vel_xy 5 m/s
    rows = _rows(0.9, n=6)
    with pytest.raises(InputError, match=r"speed 6 m/s is above x500-sprayer's top speed 5 m/s \(control\.max_vel_xy\)"):
        resolve_spray_rates(_mission(speed_mps=6.0, rate_lpha=20.0), v, rows)
    top = resolve_spray_rates(_mission(speed_mps=6.0, rate_lpha=20.0, allow_slower=True), v, rows).phases[1]
    assert isinstance(top, SprayPhase) and top.speed_mps == pytest.approx(5.0)
    plan = phase_plan(top, v, phase_rows(top, rows), (0.0, 0.0))
    assert top.flow_lps == pytest.approx(flow_for_rate(20.0, plan.flow_width_m, 5.0))  # the asked rate at 5 m/s
