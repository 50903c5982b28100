"""THE phase <-> mission-item converter (vinecli.phase_items): firmware-neutral items, the sprayer command
the caller chooses, spray phases as THE spray plan, and back to phases."""

from __future__ import annotations

import math

import pytest

from vinecli.errors import SpecError
from vinecli.geo import GeoOrigin
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.mission_items import degE7_to_enu, enu_to_degE7
from vinecli.mavlink.px4params import mission_params
from vinecli.phase_items import (
    DO_SET_ACTUATOR,
    DO_SPRAYER,
    PlanContext,
    do_set_servo,
    items_to_phases,
    phases_to_items,
    sprayer_fraction,
)
from vinecli.rows.plan import plan_rows
from vinecli.specs.mission import GotoPhase, HoldPhase, LandPhase, MissionSpec, SprayerPhase, TakeoffPhase

ORIGIN = GeoOrigin(46.0705, 11.1204, 210.0)
ROWS = [[(1.0, 0.0), (1.0, 10.0)], [(3.0, 0.0), (3.0, 10.0)]]
SQUARE = [[-20, -20], [20, -20], [20, 20], [-20, 20]]


def plan_ctx(**kw: object) -> PlanContext:
    return PlanContext(origin=ORIGIN, home_enu=(0.0, 0.0, 10.12), **kw)  # type: ignore[arg-type]


def mission(*phases: dict, **kw: object) -> MissionSpec:
    return MissionSpec.model_validate({"name": "m", "phases": list(phases), **kw})


def spray_mission(**spray: object) -> MissionSpec:
    return mission({"type": "takeoff", "altitude_agl_m": 3},
                   {"type": "spray", "height_agl_m": 2.0, "speed_mps": 1.2, "flow_lps": 0.03, "rows": ROWS, **spray},
                   {"type": "land"},
                   geofence={"polygon_enu": SQUARE, "action": "rtl", "max_altitude_agl_m": 30})


def test_phases_a_firmware_mission_cannot_fly_name_the_firmware() -> None:
    ol = {"type": "open_loop", "duration_s": 2, "rotor_speeds_rad_s": 500}
    with pytest.raises(SpecError, match="not possible with PX4"):
        phases_to_items(mission(ol), plan_ctx(firmware="PX4"), sprayer=DO_SET_ACTUATOR)
    with pytest.raises(SpecError, match="'until: empty' is not possible with ArduPilot"):
        phases_to_items(spray_mission(until="empty"), plan_ctx(nozzle_max_flow_lps=0.1, firmware="ArduPilot"),
                        sprayer=DO_SPRAYER)
    with pytest.raises(SpecError, match="no tank"):
        phases_to_items(mission({"type": "sprayer", "flow_lps": 0.05}), plan_ctx(), sprayer=DO_SET_ACTUATOR)
    with pytest.raises(SpecError, match="no tank"):
        phases_to_items(spray_mission(), plan_ctx(), sprayer=DO_SET_ACTUATOR)


def test_spray_phase_is_the_spray_plan_with_the_sprayer_on_over_the_rows_only() -> None:
    def terrain(x: float, y: float) -> float:
        return 10.0 + 0.1 * y  # 10 % slope northwards; home ground z = 10.0

    plan = phases_to_items(spray_mission(), plan_ctx(terrain_height=terrain, nozzle_max_flow_lps=0.1),
                           sprayer=DO_SET_ACTUATOR)
    items = plan.items
    assert [it.command for it in items[:3]] == [M.CMD_NAV_TAKEOFF, M.CMD_DO_CHANGE_SPEED, M.CMD_DO_SET_ACTUATOR]
    assert items[-1].command == M.CMD_NAV_LAND and items[1].param2 == pytest.approx(1.2)
    # the sprayer: off for the transit, on along each row, off after it; DO_SET_ACTUATOR set 1 (param7 = 0)
    acts = [it for it in items if it.command == M.CMD_DO_SET_ACTUATOR]
    assert [a.param1 for a in acts] == pytest.approx([0.0, 0.3, 0.0, 0.3, 0.0])
    assert all(a.z == 0.0 and math.isnan(a.param2) for a in acts)
    sprayed: list[list[tuple[float, float]]] = []  # the waypoints flown with the sprayer on, per row
    on, last = False, (0.0, 0.0)
    for it in items:
        if it.command == M.CMD_DO_SET_ACTUATOR:
            on = it.param1 > 0
            if on:
                sprayed.append([last])
        elif it.command == M.CMD_NAV_WAYPOINT:
            last = degE7_to_enu(ORIGIN, it.x, it.y)
            if on:
                sprayed[-1].append(last)
    # THE plan: the nearest row first (entered at its nearer end), then the next one the other way
    order = plan_rows(ROWS, (0.0, 0.0), speed_mps=1.2, accel_mps2=1.5).order
    assert order == [0, 1]
    assert sprayed[0][0] == pytest.approx((1.0, 0.0), abs=0.02) and sprayed[0][-1] == pytest.approx((1.0, 10.0), abs=0.02)
    assert sprayed[1][0] == pytest.approx((3.0, 10.0), abs=0.02) and sprayed[1][-1] == pytest.approx((3.0, 0.0), abs=0.02)
    # heights: 2 m above the surface (its running maximum over +-1 m), above home, relative frame
    for it in items:
        if it.command == M.CMD_NAV_WAYPOINT:
            x, y = degE7_to_enu(ORIGIN, it.x, it.y)
            assert it.frame == M.MAV_FRAME_GLOBAL_RELATIVE_ALT
            assert terrain(x, y) + 2.0 - 10.0 - 1e-3 <= it.z <= terrain(x, y) + 2.0 - 10.0 + 0.1 + 1e-3
    assert [f.command for f in plan.fence] == [5001] * 4 and all(f.param1 == 4 and f.mission_type == 1 for f in plan.fence)
    assert plan.params == {} and plan.phase_of_item[0] == 0 and plan.phase_of_item[-1] == 2


def test_the_caller_chooses_the_sprayer_command() -> None:
    ctx = plan_ctx(nozzle_max_flow_lps=0.1)
    m = mission({"type": "sprayer", "flow_lps": 0.025}, {"type": "sprayer", "flow_lps": 0.0})
    on, off = phases_to_items(m, ctx, sprayer=DO_SPRAYER).items
    assert (on.command, on.param1, off.param1) == (M.CMD_DO_SPRAYER, 1.0, 0.0)
    on, off = phases_to_items(m, ctx, sprayer=do_set_servo(10, 1100.0, 1900.0)).items
    assert (on.command, on.param1, on.param2, off.param2) == (M.CMD_DO_SET_SERVO, 10.0, 1300.0, 1100.0)
    assert sprayer_fraction(on, servo=10, pwm_off=1100.0, pwm_on=1900.0) == pytest.approx(0.25)
    assert sprayer_fraction(on, servo=9) is None  # another output
    on, _off = phases_to_items(m, ctx, sprayer=DO_SET_ACTUATOR).items
    assert (on.command, on.param1) == (M.CMD_DO_SET_ACTUATOR, 0.25) and sprayer_fraction(on) == 0.25


def test_px4_parameters_of_a_mission() -> None:
    p = mission_params(spray_mission())
    assert p["MIS_TAKEOFF_ALT"] == 3.0 and p["GF_ACTION"] == 3 and p["GF_MAX_VER_DIST"] == 30
    assert p["NAV_MC_ALT_RAD"] == pytest.approx(0.3) and "MPC_LAND_SPEED" in p


def test_items_round_trip_to_phases() -> None:
    m = mission({"type": "takeoff", "altitude_agl_m": 4}, {"type": "goto", "position_enu": [5, 6], "yaw_deg": 0, "speed_mps": 3},
                {"type": "hold", "duration_s": 2}, {"type": "sprayer", "flow_lps": 0.05}, {"type": "land"})
    plan = phases_to_items(m, plan_ctx(nozzle_max_flow_lps=0.1), sprayer=DO_SET_ACTUATOR)
    yaw_item = next(it for it in plan.items if it.command == 16)
    assert yaw_item.param4 == pytest.approx(90.0)  # ENU yaw 0 (east) = NED heading 90°
    phases, src = items_to_phases(plan.items, ORIGIN, ORIGIN.alt + 10.12, 0.1)
    kinds = [type(p) for p in phases]
    assert kinds == [TakeoffPhase, GotoPhase, GotoPhase, HoldPhase, SprayerPhase, GotoPhase, LandPhase]
    goto = phases[1]
    assert goto.position_enu == pytest.approx((5, 6), abs=0.02) and goto.speed_mps == 3 and goto.yaw_deg == pytest.approx(0.0)
    assert phases[3].duration_s == 2 and phases[4].flow_lps == pytest.approx(0.05)
    assert len(src) == len(phases) and src[0] == 0
    # ArduPilot's sprayer commands read back too
    for sprayer in (DO_SPRAYER, do_set_servo(9)):
        back, _ = items_to_phases(phases_to_items(m, plan_ctx(nozzle_max_flow_lps=0.1), sprayer=sprayer).items,
                                  ORIGIN, ORIGIN.alt + 10.12, 0.1)
        flows = [p.flow_lps for p in back if isinstance(p, SprayerPhase)]
        assert flows == pytest.approx([0.1 if sprayer is DO_SPRAYER else 0.05])
    lat, lon = enu_to_degE7(ORIGIN, 100.0, -50.0)
    assert degE7_to_enu(ORIGIN, lat, lon) == pytest.approx((100.0, -50.0), abs=0.02)


def test_headings_round_trip_on_a_crs_world() -> None:
    """On a world on a CRS grid a goto's yaw goes out as a heading from true north (turned by the grid convergence)
    and comes back as the same yaw, in MAVLink's degE7 and in a plan file's float degrees."""
    from pyproj import Transformer

    from vinecli.geo import GeoFrame

    cx, cy = Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True).transform(ORIGIN.lon, ORIGIN.lat)
    geo = GeoFrame(ORIGIN.lat, ORIGIN.lon, ORIGIN.alt, crs="EPSG:32632", crs_centre=(cx, cy))
    assert abs(math.degrees(geo.convergence_rad)) > 0.5
    m = mission({"type": "takeoff", "altitude_agl_m": 4}, {"type": "goto", "position_enu": [5, 6], "yaw_deg": 30})
    for degrees in (False, True):
        ctx = PlanContext(origin=geo, home_enu=(0.0, 0.0, 0.0), degrees=degrees)
        items = phases_to_items(m, ctx, sprayer=DO_SET_ACTUATOR).items
        assert items[1].param4 == pytest.approx(60.0 - math.degrees(geo.convergence_rad), abs=1e-9)
        back, _ = items_to_phases(items, geo, geo.alt, None, degrees=degrees)
        assert back[1].yaw_deg == pytest.approx(30.0, abs=1e-9)
        assert back[1].position_enu == pytest.approx((5.0, 6.0), abs=0.01 if not degrees else 1e-6)
