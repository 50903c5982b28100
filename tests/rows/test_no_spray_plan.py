"""A no-spray zone in the spray plan (rows/no_spray.py, rows/passes.py, rows/plan.py): the passes stay on the lines
of the block planned without the zone, close their sections the footprint's clearance before it, and each piece of
the cut row keeps its own planned stretch, ending where the full dose can still reach it."""

from __future__ import annotations

import pytest
from shapely.geometry import LineString, Polygon

from vinecli.rows.no_spray import clearance_m, taper_m
from vinecli.rows.spray_rate import phase_plan, spray_pattern
from vinecli.specs.mission import SprayPhase
from vinecli.vehicle import load_vehicle

ZONE = [(-2.0, -1.0), (2.0, -1.0), (2.0, 1.0), (-2.0, 1.0)]  # across the middle row, grown by its buffer
#: three rows along x, 2.5 m apart; the middle one cut by the zone into two 10 m pieces (as the world build cuts it)
ROWS = [[(-12.0, -2.5), (12.0, -2.5)], [(-12.0, 0.0), (-2.0, 0.0)], [(2.0, 0.0), (12.0, 0.0)],
        [(-12.0, 2.5), (12.0, 2.5)]]


def test_the_passes_close_before_the_zone_and_each_piece_keeps_its_stretch() -> None:
    v = load_vehicle("x500-sprayer")
    ph = SprayPhase(rows="world", height_agl_m=2.0, speed_mps=3.0, rate_lpha=40.0)
    plan = phase_plan(ph, v, ROWS, (-14.5, 1.25), no_spray=[ZONE])
    free = phase_plan(ph, v, ROWS, (-14.5, 1.25))
    pat = spray_pattern(v, 2.0, 3.0)
    ramp = 3.0 * max(v.sprayer.pump.tau_up_s, v.sprayer.pump.tau_down_s)
    g, t = clearance_m(pat, ramp), taper_m(pat, ramp)
    assert pat.footprint_radius_m < g < t
    zone = Polygon(ZONE)
    sprayed = [leg for leg in plan.legs if leg.spray]
    assert min(LineString(leg.points).distance(zone) for leg in sprayed) == pytest.approx(g, abs=0.02)
    # the passes are the ones of the block without the zone: straight, same lines, only cut where they cross it
    assert {round(p[1], 6) for leg in sprayed for p in leg.points} == {
        round(p[1], 6) for leg in free.legs if leg.spray for p in leg.points}
    assert all(len({round(p[1], 6) for p in leg.points}) == 1 for leg in sprayed)
    crossing = [leg for leg in free.legs if leg.spray and LineString(leg.points).distance(zone) < g]
    assert len(crossing) >= 1 and len(plan.order) == len(free.order)  # a cut pass is still one pass
    # flown across the zone with the sections closed: one more gap per pass that used to spray within g of it
    gaps = sum(leg.kind == "gap" for leg in plan.legs) - sum(leg.kind == "gap" for leg in free.legs)
    assert gaps == len({leg.lane for leg in crossing} - {leg.lane for leg in free.legs if leg.kind == "gap"})
    cut = sum(LineString(leg.points).intersection(zone.buffer(g)).length for leg in crossing)
    assert cut > 2 * (4.0 + g) and sum(leg.length_m for leg in sprayed) == pytest.approx(
        sum(leg.length_m for leg in free.legs if leg.spray) - cut, abs=0.05)
    # each piece of the cut row is planned on its own, up to where the full dose reaches it without the zone
    assert plan.stretches[1] == pytest.approx((0.0, 10.0 - t), abs=0.01)
    assert plan.stretches[2] == pytest.approx((t, 10.0), abs=0.01)
    assert plan.stretches[0] == free.stretches[0] and plan.stretches[3] == free.stretches[3]
    # the rows beside the zone keep their whole stretch; where the passes near the zone are cut, not judged
    for i in (0, 3):
        ((a, b),) = plan.holes[i]
        assert a + b == pytest.approx(24.0, abs=0.01) and b - a == pytest.approx(2 * (2.0 + (t * t - 1.5 ** 2) ** 0.5),
                                                                                  abs=0.02)
    assert 1 not in plan.holes and 2 not in plan.holes
    assert free.stretches[1] == pytest.approx((0.0, 10.0))


def test_a_firmware_mission_closes_the_sprayer_at_the_zone_too() -> None:
    """THE converter (PX4 / ArduPilot missions) plans with the world's zones from its PlanContext: every stretch
    flown with the sprayer on stays the clearance away from the zone; without them it comes within it."""
    from vinecli.geo import GeoOrigin
    from vinecli.mavlink import px4modes as M
    from vinecli.mavlink.mission_items import degE7_to_enu
    from vinecli.phase_items import DO_SET_ACTUATOR, PlanContext, phases_to_items
    from vinecli.specs.mission import MissionSpec

    v = load_vehicle("x500-sprayer")
    origin = GeoOrigin(46.0705, 11.1204, 210.0)
    m = MissionSpec.model_validate({"name": "m", "phases": [
        {"type": "takeoff", "altitude_agl_m": 3},
        {"type": "spray", "height_agl_m": 2.0, "speed_mps": 3.0, "flow_lps": 0.03, "rows": ROWS}, {"type": "land"}]})
    pat = spray_pattern(v, 2.0, 3.0)
    g = clearance_m(pat, 3.0 * max(v.sprayer.pump.tau_up_s, v.sprayer.pump.tau_down_s))

    def sprayed(zones: list) -> list[LineString]:
        ctx = PlanContext(origin=origin, home_enu=(-14.5, 1.25, 0.0), nozzle_max_flow_lps=0.1, vehicle=v,
                          no_spray_enu=zones)
        out: list[list[tuple[float, float]]] = []
        on, last = False, (-14.5, 1.25)
        for it in phases_to_items(m, ctx, sprayer=DO_SET_ACTUATOR).items:
            if it.command == M.CMD_DO_SET_ACTUATOR:
                on = it.param1 > 0
                out += [[last]] if on else []
            elif it.command == M.CMD_NAV_WAYPOINT:
                last = degE7_to_enu(origin, it.x, it.y)
                if on:
                    out[-1].append(last)
        return [LineString(s) for s in out if len(s) >= 2]

    zone = Polygon(ZONE)
    assert min(s.distance(zone) for s in sprayed([ZONE])) >= g - 0.05
    assert min(s.distance(zone) for s in sprayed([])) < 0.05
