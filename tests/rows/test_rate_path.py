"""Segment rates on THE spray plan (vinecli.rows.rate_path) and in the firmware missions built from it (PX4's
DO_SET_ACTUATOR per piece, ArduPilot's SPRAY_PUMP_RATE schedule): cuts at the segment boundaries under each pass,
litres per metre = rate x track width / 10 000, gaps closed, pieces beyond the pump slowed, changes led by the
pump's lag, short pieces joined for PX4; ArduPilot's coordinates round-trip."""

from __future__ import annotations

import math

import numpy as np
import pytest
from loopback_world import ORIGIN

from vinecli.mavlink import px4modes as M
from vinecli.phase_items import DO_SET_ACTUATOR, DO_SPRAYER, PlanContext, phases_to_items
from vinecli.rows.plan import plan_rows
from vinecli.rows.rate_path import led_changes, rate_legs, rate_path, speed_caps
from vinecli.rows.segment_rates import RateSegment, SegmentRates
from vinecli.rows.spray_rate import phase_plan, resolve_spray_rates
from vinecli.sitl.ardupilot.mission_plan import ArdupilotFrame
from vinecli.sitl.ardupilot.pump_rates import PumpRateSchedule, lead_time_s
from vinecli.specs.mission import MissionSpec, SprayPhase
from vinecli.vehicle import load_vehicle

ROWS = [[(0.0, 0.0), (0.0, 30.0)], [(4.0, 0.0), (4.0, 30.0)]]  # wider apart than the x500's swath: a pass each
#: per row: (s0, s1, rate L/ha); row 1 has a gap
PIECES = {0: ((0.0, 10.0, 20.0), (10.0, 20.0, 30.0), (20.0, 30.0, 15.0)),
          1: ((0.0, 12.0, 25.0), (12.0, 16.0, 0.0), (16.0, 30.0, 25.0))}
VEH = load_vehicle("x500-sprayer")


def _rates(scale: float = 1.0) -> SegmentRates:
    segs = tuple(RateSegment(r, a, b, (ROWS[r][0][0], a), (ROWS[r][0][0], b), rate * scale, rate == 0.0, 1.0, 0.5,
                             1.0, 0.0, 0.0) for r, ps in PIECES.items() for a, b, rate in ps)
    return SegmentRates(segs, 4.0, None, None, 30.0 * scale, "rows")


def _phase(mean: float = 22.0) -> SprayPhase:
    return SprayPhase(rows=[[list(p) for p in r] for r in ROWS], height_agl_m=2.0, speed_mps=2.0, rate_lpha=mean)


def _plan() -> object:
    return phase_plan(_phase(), VEH, ROWS, (-3.0, -3.0))


def test_passes_cut_at_the_segment_boundaries() -> None:
    plan = _plan()
    rp = rate_path(plan, _rates(), ROWS, speed_mps=2.0, flow_range_lps=(0.0, 0.1), speed_min_mps=1.0)
    w = plan.flow_width_m  # type: ignore[attr-defined]
    assert rp.per_lpha == pytest.approx(w / 1e4)
    pts = np.asarray(rp.points)
    for (a, b), f, r in zip(zip(pts[:-1], pts[1:], strict=True), rp.flows, rp.rates, strict=True):
        assert f == pytest.approx(r * w / 1e4)
        if r > 0:  # a piece over a row lies within one of its segments (the run-on past the ends: the end's rate)
            row = 0 if abs(a[0]) < 2.0 else 1
            mid = float(np.clip(0.5 * (a[1] + b[1]), 0.0, 30.0))
            want = next(rate for s0, s1, rate in PIECES[row] if s0 <= mid <= s1)
            assert r == want
    cuts = sorted({round(float(p[1]), 2) for p in pts if 0.5 < p[1] < 29.5})
    for y in (10.0, 20.0, 12.0, 16.0):  # every boundary is a cut, within the sampling step
        assert min(abs(c - y) for c in cuts) <= 0.03
    gap = [f for (a, b), f in zip(zip(pts[:-1], pts[1:], strict=True), rp.flows, strict=True)
           if abs(a[0] - 4.0) < 0.5 and 12.1 < 0.5 * (a[1] + b[1]) < 15.9]
    assert gap and all(f == 0.0 for f in gap)  # the sections close over the gap
    assert rp.notes == []


def test_rates_beyond_the_pump_are_flown_slower() -> None:
    plan = _plan()
    # the pump's 0.1 L/s at 2 m/s over the x500's ~1.0 m track (the wake-narrowed plume) is ~490 L/ha: x28 puts
    # every rate but the 15 L/ha piece's (420 L/ha) above it, with a margin either side
    scale = 28.0
    rp = rate_path(plan, _rates(scale=scale), ROWS, speed_mps=2.0, flow_range_lps=(0.0, 0.1), speed_min_mps=1.0)
    notes = {n["kind"]: n for n in rp.notes}
    above = sorted(scale * r for ps in PIECES.values() for _, _, r in ps if scale * r * rp.per_lpha * 2.0 > 0.1)
    assert above == [560.0, 700.0, 700.0, 840.0]  # above the pump's 0.1 L/s at 2 m/s: 420 L/ha is not
    assert set(notes) == {"slowed"} and notes["slowed"]["rates_lpha"] == [above[0], above[-1]]
    caps = speed_caps(rp.flows, 2.0, 0.1)
    for f, v in zip(rp.flows, caps, strict=True):
        assert v <= 2.0 and f * v <= 0.1 + 1e-12  # the pump's maximum at the capped speed
    assert min(caps) == pytest.approx(0.1 / (840.0 * rp.per_lpha))
    low = rate_path(plan, _rates(scale=0.01), ROWS, speed_mps=2.0, flow_range_lps=(0.004, 0.1), speed_min_mps=1.0)
    over = {n["kind"]: n for n in low.notes}["over-dosed"]
    assert over["pieces"] > 0 and min(f for f in low.flows if f > 0) == pytest.approx(0.004 / 2.0)


def test_changes_led_by_the_pump_and_short_pieces_joined() -> None:
    pts = [(0.0, 0.0), (0.0, 10.0), (0.0, 20.0), (0.0, 23.0), (0.0, 40.0)]
    flows = [0.0, 1.0, 2.0, 1.0]
    lp, lf = led_changes(pts, flows, lead_up_m=0.6, lead_down_m=0.3)
    starts = {round(a[1], 6): f for a, f in zip(lp[:-1], lf, strict=True)}
    assert starts[9.4] == 1.0 and starts[19.4] == 2.0 and starts[22.7] == 1.0  # rises 0.6 m, falls 0.3 m early
    assert sum(math.dist(a, b) for a, b in zip(lp[:-1], lp[1:], strict=True)) == pytest.approx(40.0)
    legs = rate_legs(pts, flows, min_leg_m=6.0)
    assert [(round(leg.length_m, 6), f) for leg, f in legs] == [(10.0, 0.0), (13.0, pytest.approx((10 + 2 * 3) / 13)),
                                                               (17.0, 1.0)]  # the 3 m piece joins the one before
    merged = rate_legs(pts, flows, merge_sprayed=True)
    assert [(leg.spray, round(leg.length_m, 6)) for leg, _ in merged] == [(False, 10.0), (True, 30.0)]


def _flight(firmware: str):
    m = MissionSpec(name="m", phases=[{"type": "takeoff", "altitude_agl_m": 3.0}, _phase().model_dump(),
                                      {"type": "land"}])
    flown = resolve_spray_rates(m, VEH)
    ctx = PlanContext(origin=ORIGIN, home_enu=(-3.0, -3.0, 0.0), nozzle_max_flow_lps=VEH.tank.nozzle_max_flow_lps,
                      firmware=firmware, vehicle=VEH, segment_rates={1: _rates()},
                      rate_items="switch" if firmware == "ArduPilot" else "actuator")
    return phases_to_items(flown, ctx, sprayer=DO_SPRAYER if firmware == "ArduPilot" else DO_SET_ACTUATOR)


def test_px4_mission_sets_each_piece_at_its_waypoint() -> None:
    items = _flight("PX4").items
    acts = [it.param1 for it in items if it.command == M.CMD_DO_SET_ACTUATOR]
    per_lpha = _plan().flow_width_m / 1e4 * 2.0 / VEH.tank.nozzle_max_flow_lps  # type: ignore[attr-defined]
    on = [a for a in acts if a > 0]
    assert {round(a / per_lpha, 3) for a in on} == {20.0, 30.0, 15.0, 25.0}  # one value per piece, row 1 twice
    assert acts[-1] == 0.0 and sum(1 for a in acts if a == 0.0) >= 4  # off before, at the gap, after each pass
    wps = [(it.x, it.y) for it in items if it.command == M.CMD_NAV_WAYPOINT]
    assert len(wps) == len(set(wps))


def test_ardupilot_switches_at_gaps_and_schedules_the_rates() -> None:
    conv = _flight("ArduPilot")
    sprayer = [it.param1 for it in conv.items if it.command == M.CMD_DO_SPRAYER]
    assert sprayer.count(1.0) == 3 and sprayer.count(0.0) == 4  # row 0 once, row 1 around its gap; off first
    _, rp = conv.rate_paths[1]
    sched = PumpRateSchedule.from_path(rp.points, rp.flows, rp.rates, VEH.tank.nozzle_max_flow_lps, lead_time_s(0.3))
    rates = [c.rate_lpha for c in sched.changes]
    assert [r for i, r in enumerate(rates) if i == 0 or r != rates[i - 1]] == rates  # only changes
    assert set(rates) == {20.0, 30.0, 15.0, 25.0}
    c = sched.changes[0]
    assert sched.due(0.0, c.x - c.dx * 2.0, c.y - c.dy * 2.0, 2.0 * c.dx, 2.0 * c.dy) is None  # 2 m ahead: not yet
    lead = 2.0 * sched.lead_s
    assert sched.due(0.1, c.x - c.dx * (lead - 0.05), c.y - c.dy * (lead - 0.05), 2.0 * c.dx, 2.0 * c.dy) is c
    assert sched.changes[0].pump_rate == pytest.approx(100.0 * rp.flows[next(i for i, f in enumerate(rp.flows) if f > 0)]
                                                      / VEH.tank.nozzle_max_flow_lps, abs=1e-4)


def test_ardupilot_coordinates_round_trip() -> None:
    fr = ArdupilotFrame((1.0, -2.0, 0.5), 441186000, -895419000, 331.0, convergence_rad=-0.0309)
    for e, n in ((0.0, 0.0), (25.0, -40.0), (-60.0, 80.0)):
        lat, lng = fr.offset_e7(e, n)
        x, y = fr.e7_to_world(lat, lng)
        assert math.hypot(x - e, y - n) < 0.02  # ArduPilot's 1e-7 degree grid: ~1 cm
    vx, vy = fr.ned_velocity_to_world(1.0, 0.0)
    assert math.atan2(vy, vx) == pytest.approx(math.pi / 2 + 0.0309)  # true north: gamma clockwise of the grid y


def test_plan_rows_without_a_pattern_has_no_track_width() -> None:
    plan = plan_rows(ROWS, (-3.0, -3.0), speed_mps=2.0, accel_mps2=1.5)
    with pytest.raises(ValueError, match="track width"):
        rate_path(plan, _rates(), ROWS, speed_mps=2.0, flow_range_lps=(0.0, 0.1), speed_min_mps=1.0)
