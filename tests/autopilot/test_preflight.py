"""Preflight (arming) checks: fence clearance geometry, plan points against the fence margin and
the terrain, and the built-in autopilot refusing to arm (status preflight_failed) on the
rigid-body double: spawn near the fence, tilted at rest, estimator without a usable GNSS."""

from __future__ import annotations

import math

import pytest
from repo_paths import VEHICLES

from vinecli.autopilot.base import RunStatus
from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.autopilot.estimator import Estimator
from vinecli.autopilot.geofence import Geofence
from vinecli.autopilot.preflight import check_plan, check_spawn_fence, check_tilt, fence_margins_m, plan_points
from vinecli.frames import quat_from_euler
from vinecli.geo import GeoOrigin
from vinecli.sim.perfect_estimator import PerfectEstimator
from vinecli.specs import load_spec
from vinecli.specs.mission import GeofenceSpec, MissionSpec
from vinecli.specs.vehicle import VehicleSpec

from .rigid_body import RigidBodyDouble

SQUARE = GeofenceSpec(polygon_enu=[(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0)], max_altitude_agl_m=10.0)
TAKEOFF = [{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "hold", "duration_s": 1.0}, {"type": "land"}]


def vehicle(**gnss: object) -> VehicleSpec:
    v = load_spec(VEHICLES / "x500.yaml", VehicleSpec)
    if gnss:
        s = v.sensors
        v = v.model_copy(update={"sensors": s.model_copy(update={"gnss": s.gnss.model_copy(update=gnss)})})
    return v


def fly(phases: list[dict], seconds: float, *, v: VehicleSpec | None = None, truth: bool = False, tilt_deg: float = 0.0,
        **ctx: object) -> tuple[RigidBodyDouble, BuiltinAutopilot, list]:
    d = RigidBodyDouble(v or vehicle())
    tilted = quat_from_euler(math.radians(tilt_deg), 0.0, 0.0)

    def hold_tilt(body: RigidBodyDouble) -> None:  # resting on a slope: the double would level it
        if tilt_deg and body.on_ground:
            body.quat = tilted

    ap = BuiltinAutopilot()
    ap.reset(d.context(MissionSpec(name="t", truth=truth, phases=phases), **ctx))
    d.fly(ap, seconds, on_step=hold_tilt)
    return d, ap, ap.drain_events()


def test_fence_clearance_inside_outside_and_ceiling() -> None:
    gf = Geofence(SQUARE, (0.0, 0.0, 1.0))
    assert gf.clearance((4.0, 0.0, 3.0)) == pytest.approx((1.0, 8.0))
    assert gf.clearance((0.0, 0.0, 1.0))[0] == pytest.approx(5.0)
    assert gf.clearance((6.0, 6.0, 12.0)) == pytest.approx((-math.sqrt(2.0), -1.0))
    cyl = Geofence(GeofenceSpec(max_horizontal_distance_m=3.0), (1.0, 1.0, 0.0))
    assert cyl.clearance((1.0, 3.0, 0.0)) == pytest.approx((1.0, math.inf))


def test_margin_is_three_sigma_of_the_estimates_uncertainty() -> None:
    """The autopilot's estimator reports the GNSS noise; the simulator's perfect estimator none."""
    v = vehicle(horizontal_noise_m=0.3, vertical_noise_m=0.5)
    est = Estimator(v, GeoOrigin(45.0, 8.0, 200.0))
    assert fence_margins_m(est.sigma_h_m, est.sigma_v_m) == pytest.approx((0.9, 1.5))
    perfect = PerfectEstimator()
    assert fence_margins_m(perfect.sigma_h_m, perfect.sigma_v_m) == (0.0, 0.0)


def test_spawn_fence_check() -> None:
    assert check_spawn_fence(SQUARE, (3.0, 0.0, 0.0), 0.9) is None
    near = check_spawn_fence(SQUARE, (4.5, 0.0, 0.0), 0.9)
    assert near is not None and near.check == "geofence_spawn" and near.value == pytest.approx(0.5)
    assert "0.50 m inside, needs 0.90 m" in near.message
    out = check_spawn_fence(SQUARE, (6.0, 0.0, 0.0), 0.9)
    assert out is not None and "outside the geofence" in out.message
    assert check_spawn_fence(SQUARE.model_copy(update={"action": "none"}), (6.0, 0.0, 0.0), 0.9) is None


def test_plan_points_against_fence_margin_and_terrain() -> None:
    home = (0.0, 0.0, 0.1)
    mission = MissionSpec(name="m", phases=[
        {"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "goto", "position_enu": [4.5, 0.0]},
        {"type": "waypoints", "waypoints": [[0.0, 3.0, 9.5]]}, {"type": "land"}])
    pts = plan_points(mission, home, [], None, 0.1)
    assert [(p.x, p.y, p.z_rel) for p in pts] == [(0.0, 0.0, 3.0), (4.5, 0.0, 3.0), (0.0, 3.0, 9.5)]
    fails = check_plan(pts, SQUARE, home, (0.9, 1.5), (-20.0, -20.0, 20.0, 20.0))
    assert [f.check for f in fails] == ["geofence_plan"]
    assert "phase 1 (goto) at (4.50, 0.00) is 0.50 m inside the geofence, needs 0.90 m" in fails[0].message
    # the goto moved well inside: the 9.5 m waypoint under the 10 m ceiling is the next failure
    pts[1] = pts[1].__class__("goto", 2.0, 0.0, 3.0)
    fails = check_plan(pts, SQUARE, home, (0.9, 1.5), (-20.0, -20.0, 20.0, 20.0))
    assert [f.check for f in fails] == ["geofence_plan"] and "below the geofence ceiling" in fails[0].message
    assert check_plan(pts, SQUARE, home, (0.0, 0.0), (-20.0, -20.0, 20.0, 20.0)) == []
    off = check_plan(pts, None, home, (0.9, 1.5), (-1.0, -1.0, 1.0, 1.0))
    assert [f.check for f in off] == ["plan_off_terrain"] and "outside the terrain" in off[0].message


def test_spray_rows_are_planned_points() -> None:
    rows = (((1.0, -2.0), (1.0, 2.0)), ((2.0, -2.0), (2.0, 2.0)))
    mission = MissionSpec(name="m", phases=[{"type": "takeoff", "altitude_agl_m": 3.0},
                                            {"type": "spray", "rows": "world", "height_agl_m": 2.0, "flow_lps": 0.01}])
    pts = plan_points(mission, (0.0, 0.0, 0.1), rows, lambda x, y: 0.5, 0.1)
    assert [(p.x, p.y) for p in pts[1:]] == [(1.0, -2.0), (1.0, 2.0), (2.0, -2.0), (2.0, 2.0)]
    assert all(p.z_rel == pytest.approx(0.5 + 0.1 + 2.0 - 0.1) for p in pts[1:])  # 2 m over the terrain


def test_spray_path_is_checked_as_flown_clipped_to_the_fence() -> None:
    """With the vehicle's acceleration the spray phase's points are the path it flies: the rows clipped
    to the fence (1 m margin) with headland turns - so rows that run past the fence do not block arming
    (as the spray phase clips them), and every path point keeps the fence margin."""
    rows = (((-2.0, -8.0), (-2.0, 8.0)), ((0.0, -8.0), (0.0, 8.0)), ((2.0, -8.0), (2.0, 8.0)))  # past y = +-5
    fence = SQUARE.model_copy(update={"max_altitude_agl_m": 20.0})
    mission = MissionSpec(name="m", phases=[{"type": "takeoff", "altitude_agl_m": 3.0},
                                            {"type": "spray", "rows": "world", "height_agl_m": 2.0, "flow_lps": 0.01}])
    home = (0.0, -3.0, 0.0)
    raw = plan_points(mission, home, rows, lambda x, y: 0.0, 0.0)
    fails = check_plan(raw, fence, home, (0.9, 1.5), None)
    assert [f.check for f in fails] == ["geofence_plan"] and "row point" in fails[0].message
    flown = plan_points(mission, home, rows, lambda x, y: 0.0, 0.0, fence=fence, accel_mps2=1.5)
    assert check_plan(flown, fence, home, (0.9, 1.5), None) == []
    spray = [p for p in flown if "path point" in p.label]
    turns = [p for p in flown if p.turn]
    assert turns and all("turn" in p.label or "transit" in p.label for p in turns)
    assert spray and max(abs(p.y) for p in spray) <= 4.0 + 1e-6  # clipped 1 m inside the fence
    assert {round(p.x, 6) for p in spray} >= {-2.0, 0.0, 2.0}  # every row is flown


def test_tilt_check() -> None:
    assert check_tilt(math.radians(29.0), vehicle()) is None
    f = check_tilt(math.radians(172.0), vehicle())
    assert f is not None and f.check == "tilt" and "tilted 172.0 deg at rest (limit 30 deg)" in f.message


def test_spawn_near_the_fence_is_not_armed() -> None:
    fence = GeofenceSpec(polygon_enu=[(-5.0, -5.0), (0.5, -5.0), (0.5, 5.0), (-5.0, 5.0)], action="hold")
    d, ap, ev = fly(TAKEOFF, 10, geofence=fence)
    st = ap.status()
    assert st.status is RunStatus.PREFLIGHT_FAILED
    assert "geofence_spawn" in st.detail and "0.50 m inside" in st.detail
    assert not any(e.kind == "arming" for e in ev) and d.on_ground
    pre = [e for e in ev if e.kind == "preflight"]
    assert len(pre) == 1 and pre[0].data["check"] == "geofence_spawn"
    assert 1.4 < pre[0].t_us * 1e-6 < 2.0  # when it would have armed (estimator converged)


def test_plan_outside_the_fence_is_not_armed() -> None:
    fence = GeofenceSpec(polygon_enu=[(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0)])
    d, ap, ev = fly([{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "goto", "position_enu": [15.0, 0.0]}], 10,
                    geofence=fence)
    assert ap.status().status is RunStatus.PREFLIGHT_FAILED and "phase 1 (goto)" in ap.status().detail


def test_plan_off_the_terrain_is_not_armed() -> None:
    d, ap, ev = fly([{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "goto", "position_enu": [15.0, 0.0]}], 10,
                    terrain_bounds=(-10.0, -10.0, 10.0, 10.0))
    assert ap.status().status is RunStatus.PREFLIGHT_FAILED and "plan_off_terrain" in ap.status().detail


@pytest.mark.parametrize("truth", [False, True])
def test_tilted_at_rest_is_not_armed(truth: bool) -> None:
    d, ap, ev = fly(TAKEOFF, 10, tilt_deg=40.0, truth=truth)
    st = ap.status()
    assert st.status is RunStatus.PREFLIGHT_FAILED and "'tilt'" in st.detail
    tilt = next(e for e in ev if e.kind == "preflight").data["value"]
    assert tilt == pytest.approx(40.0, abs=3.0)  # the estimate of the tilt (truth: exact)
    assert not any(e.kind == "arming" for e in ev)


def test_level_enough_is_armed() -> None:
    d, ap, ev = fly(TAKEOFF, 30, tilt_deg=20.0)
    assert any(e.kind == "arming" for e in ev)


def test_estimator_without_a_usable_gnss_is_not_armed() -> None:
    d, ap, ev = fly(TAKEOFF, 20, v=vehicle(satellites=4))
    st = ap.status()
    assert st.status is RunStatus.PREFLIGHT_FAILED
    assert "'estimator'" in st.detail and "not converged after 10 s" in st.detail and "GNSS 4 satellites < 6" in st.detail
    assert next(e for e in ev if e.kind == "preflight").t_us == pytest.approx(10e6, abs=0.05e6)

