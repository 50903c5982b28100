"""Operator plans over rows: nearest row first, boustrophedon, headland turns from speed and acceleration,
spray only over the rows, fence clipping with warnings, time estimates, sorties and their .plan files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vinecli.geo import GeoOrigin
from vinecli.missions.qgc_export import sortie_plan
from vinecli.phase_items.spray_legs import leg_actions
from vinecli.rows.plan import Leg, plan_rows, split_sorties

ORIGIN = GeoOrigin(44.70, 8.03, 250.0)


def block(n: int = 6, spacing: float = 2.5, length: float = 30.0, x0: float = 0.0) -> list[list[tuple[float, float]]]:
    """``n`` rows running north, ``spacing`` apart from x = x0, y = 0 .. length."""
    return [[(x0 + i * spacing, 0.0), (x0 + i * spacing, length)] for i in range(n)]


def test_starts_at_the_row_nearest_take_off_and_alternates() -> None:
    rows = block()
    plan = plan_rows(rows, (14.0, -3.0), speed_mps=2.0, accel_mps2=1.5)  # east of the block, south end
    assert plan.order == [5, 4, 3, 2, 1, 0]
    legs = [leg for leg in plan.legs if leg.spray]
    assert legs[0].points[0] == (12.5, 0.0)  # entered at the nearer end
    dirs = [math.copysign(1.0, leg.points[-1][1] - leg.points[0][1]) for leg in legs]
    assert dirs == [1, -1, 1, -1, 1, -1]
    # the transit ends with a straight run-in of v^2 / 2a along the first row: at speed where it starts
    run_in = 2.0**2 / (2 * 1.5)
    assert plan.legs[0].kind == "transit" and plan.legs[0].points[-2] == pytest.approx((12.5, -run_in))
    assert plan.legs[0].length_m == pytest.approx(math.hypot(1.5, 3.0 - run_in) + run_in)


def test_start_in_the_middle_does_the_near_side_first_then_jumps() -> None:
    plan = plan_rows(block(), (5.2, -2.0), speed_mps=2.0, accel_mps2=1.5)
    assert plan.order[0] == 2 and sorted(plan.order) == list(range(6))
    assert plan.order == [2, 1, 0, 3, 4, 5]
    assert [leg.kind for leg in plan.legs].count("transit") == 2


@pytest.mark.parametrize(("speed", "accel", "spacing", "kind"), [(2.0, 1.5, 2.5, "turn-stop"), (1.0, 2.0, 2.5, "turn-arc"),
                                                                  (3.0, 1.5, 0.9, "turn-stop")])
def test_headland_turns_sized_from_speed_and_acceleration(speed: float, accel: float, spacing: float,
                                                          kind: str) -> None:
    plan = plan_rows(block(3, spacing), (0.0, -1.0), speed_mps=speed, accel_mps2=accel)
    turns = [leg for leg in plan.legs if leg.kind.startswith("turn")]
    assert [t.kind for t in turns] == [kind, kind]
    top = max(p[1] for p in turns[0].points)
    if kind == "turn-stop":  # run out v^2 / (2 a) past the row end: the vehicle brakes after the last sprayed metre
        assert top - 30.0 == pytest.approx(speed**2 / (2 * accel))
    else:  # a semicircle of radius spacing / 2 at cruise speed: v^2 / r <= a
        assert top - 30.0 == pytest.approx(spacing / 2, abs=0.01)
        assert speed**2 / (spacing / 2) <= accel
    assert not any(t.spray for t in turns)


def test_time_estimate_from_trapezoids() -> None:
    v, a = 2.0, 1.5
    plan = plan_rows(block(2, 2.5, 30.0), (0.0, 0.0), speed_mps=v, accel_mps2=a)
    # rows at cruise speed; stop turn: brake (v/a), cross 2.5 m rest to rest, run in (v/a)
    cross = 2.5 / v + v / a if 2.5 >= v * v / a else 2 * math.sqrt(2.5 / a)
    # starting on the first row: back out v^2 / 2a (rest to rest) and run in along it (accelerating, v / a)
    run_in = v * v / (2 * a)
    back = 2 * math.sqrt(run_in / a)
    assert plan.time_s == pytest.approx(back + v / a + 60.0 / v + 2 * v / a + cross, abs=0.1)
    assert plan.spray_length_m == pytest.approx(60.0)
    assert plan.length_m == pytest.approx(2 * run_in + 60.0 + 2.5 + 2 * v * v / (2 * a))
    climb = plan_rows(block(2, 2.5, 30.0), (0.0, 0.0), speed_mps=v, accel_mps2=a, climb=(3.0, 3.0, 1.5))
    assert climb.time_s == pytest.approx(plan.time_s + 1.0 + 2.0, abs=0.1)


def test_rows_clipped_to_the_fence_with_a_margin_and_the_turns_fitted_inside() -> None:
    fence = [(-3.0, -3.0), (15.0, -3.0), (15.0, 25.0), (-3.0, 25.0)]  # rows run to y = 30: past the fence
    plan = plan_rows(block(), (0.0, -2.0), speed_mps=2.0, accel_mps2=1.5, fence_enu=fence, fence_margin_m=1.0)
    ys = [p[1] for leg in plan.legs for p in leg.points]
    assert max(ys) <= 25.0 - 1.0 + 1e-6  # the headland turns too stay inside the fence - margin
    # the rows are sprayed up to the fence margin: the turns there have no run-out (the vehicle brakes in the row)
    assert max(p[1] for leg in plan.legs if leg.spray for p in leg.points) == pytest.approx(24.0)
    assert plan.stretches[0] == pytest.approx((0.0, 24.0))
    # at the south end (y = 0, 2 m inside the margin) the full run-out v^2 / 2a = 1.33 m fits
    assert min(ys[1:]) == pytest.approx(-2.0 ** 2 / (2 * 1.5))
    assert len(plan.warnings) == 2 and "geofence" in plan.warnings[0] and "headland turns shortened" in plan.warnings[1]
    inside = plan_rows(block(), (0.0, -2.0), speed_mps=2.0, accel_mps2=1.5,
                       fence_enu=[(-5.0, -5.0), (20.0, -5.0), (20.0, 40.0), (-5.0, 40.0)])
    assert inside.warnings == []


def test_rows_wholly_outside_the_fence_are_dropped_and_the_indices_kept() -> None:
    fence = [(4.0, -3.0), (15.0, -3.0), (15.0, 35.0), (4.0, 35.0)]  # rows 0 and 1 (x = 0, 2.5) are outside
    plan = plan_rows(block(), (14.0, -2.0), speed_mps=1.0, accel_mps2=1.5, fence_enu=fence, fence_margin_m=0.5)
    assert plan.order == [5, 4, 3, 2]
    assert "2 of 6 rows leave the geofence" in plan.warnings[0] or "6 of 6 rows" in plan.warnings[0]


def test_rows_leaving_the_terrain_warn() -> None:
    plan = plan_rows(block(), (0.0, -2.0), speed_mps=2.0, accel_mps2=1.5, terrain_bounds=(-5.0, -5.0, 20.0, 20.0))
    assert len(plan.warnings) == 2 and "terrain" in plan.warnings[0]
    assert "headland turns shortened to fit the terrain" in plan.warnings[1]  # the path too stays on the map
    assert max(p[1] for leg in plan.legs for p in leg.points) <= 20.0
    assert max(p[1] for leg in plan.legs if leg.spray for p in leg.points) == pytest.approx(20.0)


def test_sorties_split_by_tank_volume() -> None:
    plan = plan_rows(block(4, 2.5, 30.0), (0.0, -2.0), speed_mps=2.0, accel_mps2=1.5)
    flow, tank = 0.05, 1.0  # 0.025 L/m: a tank sprays 40 m
    sorties = split_sorties(plan, flow, tank)
    litres = [sum(leg.length_m for leg in s if leg.spray) * flow / 2.0 for s in sorties]
    assert len(sorties) == 3 and all(v <= tank + 1e-9 for v in litres)
    assert sum(litres) == pytest.approx(120.0 * flow / 2.0)
    assert all(s[0].spray for s in sorties)  # a sortie starts on its first row (the transit is added at export)
    # the breakpoint: the second sortie resumes where the first one stopped spraying
    end1 = [leg for leg in sorties[0] if leg.spray][-1].points[-1]
    assert sorties[1][0].points[0] == pytest.approx(end1)


def test_sortie_plan_items() -> None:
    plan = plan_rows(block(4, 2.5, 30.0), (0.0, -2.0), speed_mps=2.0, accel_mps2=1.5)
    sorties = split_sorties(plan, 0.05, 1.0)
    doc = sortie_plan(sorties[1], ORIGIN, (0.0, -2.0, 0.0), height_m=2.0, speed_mps=2.0, flow_lps=0.05,
                      nozzle_max_flow_lps=0.1, takeoff_m=3.0, fence_enu=[(-5, -5), (20, -5), (20, 40), (-5, 40)])
    items = doc["mission"]["items"]
    cmds = [it["command"] for it in items]
    assert cmds[0] == 22 and cmds[1] == 178 and cmds[-1] == 20  # take-off, speed, ..., return to launch
    on = [it["params"][0] for it in items if it["command"] == 187]
    assert on == [0.0] + [0.5, 0.0] * (len(on) // 2) and len(on) >= 3  # off for the transit, on over each row
    assert [it["doJumpId"] for it in items] == list(range(1, len(items) + 1))
    assert len(doc["geoFence"]["polygons"]) == 1


def test_terrain_following_heights() -> None:
    """On a 10 % slope, the waypoints along a row keep the set height above the surface (relative to home)."""
    plan = plan_rows([[(0.0, 0.0), (0.0, 30.0)]], (0.0, -1.0), speed_mps=2.0, accel_mps2=1.5)

    def surface(x: float, y: float) -> float:
        return 0.1 * y + (0.5 if 10.0 <= y <= 12.0 else 0.0)  # slope plus a 0.5 m tall block of canopy

    acts = leg_actions(plan.legs, height_m=2.0, flow_lps=0.05, surface=surface, home_z=surface(0.0, -1.0))
    wps = [(a[1], a[2], a[3]) for a in acts if a[0] == "wp"]
    for x, y, alt in wps:
        assert alt >= surface(x, y) + 2.0 - surface(0.0, -1.0) - 0.21
    assert any(alt > 0.1 * y + 2.0 + 0.1 + 0.4 for x, y, alt in wps if 9.0 <= y <= 13.0)  # lifted over the canopy
    assert len(wps) < 20  # not one waypoint per sample


def test_world_build_warns_once_when_detected_rows_leave_the_fence(caplog: pytest.LogCaptureFixture) -> None:
    import logging

    from vinecli.specs.mission import GeofenceSpec
    from vinecli.world.build import _warn_rows_outside

    fence = GeofenceSpec(polygon_enu=[(-3.0, -3.0), (15.0, -3.0), (15.0, 25.0), (-3.0, 25.0)])
    with caplog.at_level(logging.WARNING):
        _warn_rows_outside(block(), [-10.0, -10.0, 40.0, 40.0], fence, "w")
    lines = [r.getMessage() for r in caplog.records]
    assert lines == ["world w: 6 of 6 detected rows leave the geofence (up to 5.0 m outside); plans clip them"]


@pytest.mark.parametrize("spacing", [2.5, 4.0])  # passes between the rows (broadcast) / one pass per row
def test_a_row_cut_by_a_no_spray_zone_gets_a_pass_per_stretch_and_none_over_the_gap(spacing: float) -> None:
    """Three rows, the middle one cut into two stretches by a zone 4 m long (GIS no_spray): every stretch is
    flown with the sprayer on, the pass runs straight across the gap with it off, and no spraying leg enters the
    gap (the plan used to interpolate one pass between the two stretches, right over the zone)."""
    from shapely.geometry import LineString, box

    from vinecli.rows.spray_rate import spray_pattern
    from vinecli.specs.mission import SprayPhase
    from vinecli.vehicle import load_vehicle

    veh = load_vehicle("x500-sprayer")
    pattern = spray_pattern(veh, 2.0, 3.0, 1.225)
    rows = [[(-12.0, -spacing), (12.0, -spacing)], [(-12.0, 0.0), (-2.0, 0.0)], [(2.0, 0.0), (12.0, 0.0)],
            [(-12.0, spacing), (12.0, spacing)]]
    plan = plan_rows(rows, (-14.0, -spacing), speed_mps=3.0, accel_mps2=1.5, pattern=pattern, band_m=0.6)
    gap = box(-1.99, -0.3, 1.99, 0.3)
    spraying = [leg for leg in plan.legs if leg.spray]
    assert all(LineString(leg.points).intersection(gap).length < 1e-6 for leg in spraying)
    reach = 0.05 if plan.layout is not None and plan.layout.mode == "rows" else 0.6 * plan.layout.spacing_m
    sprayed = [LineString(leg.points) for leg in spraying]
    for r in rows:  # every point of every stretch within reach of a spraying leg (over it, or a lane beside it)
        line = LineString(r)
        for d in np.arange(0.0, line.length + 1e-9, 0.25):
            assert min(s.distance(line.interpolate(d)) for s in sprayed) <= reach
    gaps = [leg for leg in plan.legs if leg.kind == "gap"]
    assert gaps and all(not leg.spray and len(leg.points) == 2 for leg in gaps)
    assert SprayPhase  # the phase's plan goes through the same plan_rows (rows.spray_rate.phase_plan)


def test_terrain_following_legs_are_long_enough_for_a_firmware_to_keep_its_speed() -> None:
    """A 0.3 m canopy bump 2 m long on a flat row (the sample vineyard has such): no waypoint within MIN_LEG_M of
    the next on the straight pass (PX4 and ArduPilot slow down at short legs and bends), the path still clears the
    canopy by the set height (0.1 m tolerance) and flat ground gives no waypoint at all."""
    from vinecli.phase_items.spray_legs import MIN_LEG_M

    def surface(x: float, y: float) -> float:
        return 0.3 if 20.0 <= y <= 22.0 else 0.0

    acts = leg_actions([Leg([(0.0, 0.0), (0.0, 60.0)], True, 0)], height_m=2.0, flow_lps=0.05, surface=surface)
    wps = [(a[2], a[3]) for a in acts if a[0] == "wp"]
    assert 3 <= len(wps) <= 6, wps
    assert all(b[0] - a[0] >= MIN_LEG_M - 0.5 for a, b in zip(wps[:-1], wps[1:], strict=True)), wps
    for y in np.arange(0.0, 60.0, 0.25):
        alt = float(np.interp(y, [w[0] for w in wps], [w[1] for w in wps]))
        assert alt >= surface(0.0, y) + 2.0 - 0.1 - 1e-9, (y, alt)
    flat = leg_actions([Leg([(0.0, 0.0), (0.0, 60.0)], True, 0)], height_m=2.0, flow_lps=0.05,
                       surface=lambda x, y: 0.0)
    assert [(a[2], a[3]) for a in flat if a[0] == "wp"] == [(0.0, 2.0), (60.0, 2.0)]


def test_a_pass_is_one_leg_from_its_run_on_through_the_row_and_the_run_in_faces_along_it() -> None:
    """A firmware mission of a pass run on past both row ends (the x500-sprayer's pattern): the row ends are on the
    straight line of the run-on, so no waypoint there (a short run-on leg held ArduCopter's S-curve at 0.9 m/s, below
    AC_Sprayer's 1 m/s minimum); the transit's run-in point carries the pass's heading (PX4 turned 180 deg while
    accelerating out of it and tracked 0.3 m beside the row)."""
    from vinecli.rows.spray_rate import spray_pattern
    from vinecli.vehicle import load_vehicle

    pattern = spray_pattern(load_vehicle("x500-sprayer"), 2.0, 2.0, 1.225)
    plan = plan_rows([[(0.0, 0.0), (0.0, 40.0)]], (-2.0, 5.0), speed_mps=2.0, accel_mps2=1.5, pattern=pattern)
    legs = [leg.kind for leg in plan.legs]
    assert legs == ["transit", "row"] and len(plan.legs[0].points) == 3  # a run-in behind the pass start
    run_in, start = plan.legs[0].points[1:]
    assert start[1] < -1.0 and run_in[1] < start[1]  # the pass starts its run-on before the row, the run-in behind
    acts = leg_actions(plan.legs, height_m=2.0, flow_lps=0.05)
    wps = [a[1:3] for a in acts if a[0] == "wp"]
    assert all(abs(y) > 0.5 and abs(y - 40.0) > 0.5 for _, y in wps)  # no waypoint at either row end
    face = [i for i, a in enumerate(acts) if a[0] == "face"]
    assert len(face) == 1 and acts[face[0] - 1][1:3] == run_in  # the run-in waypoint's yaw ...
    assert acts[face[0]][1] == pytest.approx(math.pi / 2)  # ... along the pass (north, ENU yaw)
    on = next(i for i, a in enumerate(acts) if a[0] == "spray" and a[1] > 0)
    assert [a[0] for a in acts[on + 1:]] == ["wp", "spray"]  # the sprayer on at the pass start, one leg to its end
