"""Geofence: point-in-polygon (convex, concave, edges), altitude and cylinder limits, breach
counting and GF_ACTION numbering."""

from __future__ import annotations

import pytest

from vinecli.autopilot.geofence import GF_ACTION, Geofence, point_in_polygon
from vinecli.specs.mission import GeofenceSpec

SQUARE = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]
L_SHAPE = [(0.0, 0.0), (10.0, 0.0), (10.0, 4.0), (4.0, 4.0), (4.0, 10.0), (0.0, 10.0)]


@pytest.mark.parametrize("pt, inside", [((5.0, 5.0), True), ((-0.1, 5.0), False), ((10.1, 5.0), False),
                                        ((5.0, 10.5), False), ((0.0, 0.0), True), ((10.0, 5.0), True), ((5.0, 0.0), True)])
def test_square(pt: tuple[float, float], inside: bool) -> None:
    assert point_in_polygon(*pt, SQUARE) is inside


@pytest.mark.parametrize("pt, inside", [((2.0, 8.0), True), ((8.0, 2.0), True), ((8.0, 8.0), False), ((5.0, 5.0), False),
                                        ((4.0, 7.0), True), ((3.9, 4.1), True), ((4.1, 4.1), False)])
def test_concave_polygon(pt: tuple[float, float], inside: bool) -> None:
    assert point_in_polygon(*pt, L_SHAPE) is inside


def test_vertex_order_does_not_matter() -> None:
    for pt in [(2.0, 8.0), (8.0, 8.0), (5.0, 5.0), (1.0, 1.0)]:
        assert point_in_polygon(*pt, L_SHAPE) == point_in_polygon(*pt, L_SHAPE[::-1])


def test_limits_relative_to_home() -> None:
    home = (100.0, 50.0, 20.0)
    gf = Geofence(GeofenceSpec(max_altitude_agl_m=30.0, max_horizontal_distance_m=15.0,
                               polygon_enu=[(90.0, 40.0), (120.0, 40.0), (120.0, 70.0), (90.0, 70.0)]), home)
    assert gf.violation((100.0, 50.0, 49.9)) == ""
    assert gf.violation((100.0, 50.0, 50.1)) == "max_altitude"
    assert gf.violation((114.0, 50.0, 25.0)) == ""
    assert gf.violation((100.0, 65.5, 25.0)) == "max_distance"
    gf2 = Geofence(GeofenceSpec(polygon_enu=[(90.0, 40.0), (120.0, 40.0), (120.0, 70.0), (90.0, 70.0)]), home)
    assert gf2.violation((89.0, 50.0, 25.0)) == "polygon"


def test_breach_needs_consecutive_samples_and_fires_once_per_episode() -> None:
    gf = Geofence(GeofenceSpec(max_horizontal_distance_m=5.0, action="rtl"), (0.0, 0.0, 0.0), count=3, rearm=4)
    out, inside = (6.0, 0.0, 1.0), (1.0, 0.0, 1.0)
    assert [gf.check(out) for _ in range(2)] == ["", ""]
    assert gf.check(inside) == ""  # the count restarts
    assert [gf.check(out) for _ in range(5)] == ["", "", "max_distance", "", ""]
    assert gf.breached
    assert [gf.check(inside) for _ in range(3)] == ["", "", ""]
    assert gf.breached  # not yet back inside for `rearm` checks
    gf.check(inside)
    assert not gf.breached
    assert [gf.check(out) for _ in range(3)] == ["", "", "max_distance"]  # a new episode fires again


def test_an_estimate_jittering_across_the_fence_is_one_episode() -> None:
    """A noisy position estimate near the fence: one breach, not one per re-entry (the ~115 warnings)."""
    gf = Geofence(GeofenceSpec(polygon_enu=[(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0)]), (0.0, 0.0, 0.0))
    pattern = [(5.2, 0.0, 1.0)] * 3 + [(4.9, 0.0, 1.0)] * 2
    fired = [v for _ in range(40) for p in pattern if (v := gf.check(p))]
    assert fired == ["polygon"]


def test_px4_action_numbers() -> None:
    assert GF_ACTION == {"none": 0, "warn": 1, "hold": 2, "rtl": 3, "terminate": 4, "land": 5}
