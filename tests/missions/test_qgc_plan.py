"""QGroundControl .plan import/export (tests/data/vineyard_spray.plan: QGC-style plan with a survey)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from pyproj import Transformer

from vinecli.errors import SpecError
from vinecli.geo import GeoFrame, GeoOrigin
from vinecli.missions.qgc_export import export_plan
from vinecli.missions.qgc_format import write_plan
from vinecli.missions.qgc_import import import_plan
from vinecli.specs.mission import (
    GotoPhase,
    HoldPhase,
    LandPhase,
    MissionSpec,
    RtlPhase,
    SprayerPhase,
    SprayPhase,
    TakeoffPhase,
    WaypointsPhase,
)

ORIGIN = GeoOrigin(44.7000, 8.0300, 250.0)


@pytest.fixture()
def plan_file(test_data: Path) -> Path:
    return test_data / "vineyard_spray.plan"


def test_import_maps_items_to_phases(plan_file: Path) -> None:
    m = import_plan(plan_file, ORIGIN, nozzle_max_flow_lps=0.1)
    types = [p.type for p in m.phases]
    assert types == [
        "takeoff", "waypoints", "sprayer", "waypoints", "hold", "sprayer",       # row 1 (hold 0.5 s at its end)
        "waypoints", "sprayer", "waypoints", "sprayer",                          # survey transect 1
        "waypoints", "sprayer", "waypoints", "sprayer",                          # survey transect 2
        "goto", "hold", "hold", "rtl",                                           # loiter 3 s, delay 2 s, RTL
    ]
    assert isinstance(m.phases[0], TakeoffPhase) and m.phases[0].altitude_agl_m == 4.0
    wp = m.phases[1]
    assert isinstance(wp, WaypointsPhase) and wp.speed_mps == 1.5
    x, y, h = wp.waypoints[0]
    assert (x, y, h) == pytest.approx((5.0, 2.0, 2.5), abs=2e-3)  # lat/lon -> ENU about the world origin
    on = m.phases[2]
    assert isinstance(on, SprayerPhase) and on.flow_lps == pytest.approx(0.05)  # p1 0.5 of 0.1 L/s
    assert isinstance(m.phases[4], HoldPhase) and m.phases[4].duration_s == 0.5
    survey = m.phases[6]
    assert isinstance(survey, WaypointsPhase) and survey.waypoints[0][:2] == pytest.approx((25.0, 4.5), abs=2e-3)
    loiter = m.phases[14]
    assert isinstance(loiter, GotoPhase) and loiter.position_enu == pytest.approx((10.0, 10.0), abs=2e-3)
    assert loiter.altitude_agl_m == 3.0
    assert m.phases[15].duration_s == 3.0 and m.phases[16].duration_s == 2.0
    assert isinstance(m.phases[-1], RtlPhase)
    gf = m.geofence
    assert gf is not None and gf.max_horizontal_distance_m == 60
    assert gf.polygon_enu is not None and gf.polygon_enu[0] == pytest.approx((-5.0, -5.0), abs=2e-3)
    assert m.name == "vineyard_spray" and m.max_duration_s >= 60


def _mutate(plan_file: Path, tmp_path: Path, fn) -> Path:
    data = json.loads(plan_file.read_text())
    fn(data)
    p = tmp_path / "bad.plan"
    p.write_text(json.dumps(data))
    return p


@pytest.mark.parametrize(
    ("mutate", "needle"),
    [
        (lambda d: d["mission"]["items"].__setitem__(3, {**d["mission"]["items"][3], "command": 206}),
         "mission.items[3]: unsupported command 206"),
        (lambda d: d["mission"]["items"][6]["TransectStyleComplexItem"]["Items"][2].__setitem__("command", 2000),
         "mission.items[6].TransectStyleComplexItem.Items[2]: unsupported command 2000"),
        (lambda d: d["mission"]["items"][2].__setitem__("frame", 6), "mission.items[2]: unsupported frame 6"),
        (lambda d: d.__setitem__("fileType", "Mission"), "fileType"),
        (lambda d: d["mission"]["items"][2].__setitem__("params", [0, 0]), "params"),
        (lambda d: d["geoFence"]["polygons"][0].__setitem__("inclusion", False), "geoFence.polygons[0]"),
        (lambda d: d["mission"]["items"][2].__setitem__("params", [0, 0, 0, None, None, None, 2.5]),
         "mission.items[2]: waypoint without a position"),
        (lambda d: d["mission"]["items"][4]["params"].__setitem__(6, None), "mission.items[4]: altitude (param 7)"),
        (lambda d: d["mission"]["items"][0]["params"].__setitem__(6, 0), "mission.items[0]: takeoff altitude"),
        (lambda d: d["mission"]["items"].__setitem__(5, {**d["mission"]["items"][5], "command": 183,
                                                         "params": [9, None, 0, 0, 0, 0, 0]}),
         "mission.items[5]: DO_SET_SERVO without a PWM"),
        (lambda d: d["mission"]["items"][8]["params"].__setitem__(0, 0), "mission.items[8]: a delay needs seconds"),
    ],
)
def test_import_errors_name_the_item(plan_file: Path, tmp_path: Path, mutate, needle: str) -> None:
    p = _mutate(plan_file, tmp_path, mutate)
    with pytest.raises(SpecError) as ei:
        import_plan(p, ORIGIN)
    assert needle in str(ei.value) and "bad.plan" in str(ei.value)


def test_terrain_frame_altitudes_are_above_home(plan_file: Path, tmp_path: Path) -> None:
    """Frame 10 (MAV_FRAME_GLOBAL_TERRAIN_ALT) reads as above home, like frame 3; frame 0 is AMSL minus home."""
    def frames(d):
        d["mission"]["items"][2]["frame"] = 10
        d["mission"]["items"][4] = {**d["mission"]["items"][4], "frame": 0,
                                    "params": [*d["mission"]["items"][4]["params"][:6], 252.5]}

    m = import_plan(_mutate(plan_file, tmp_path, frames), ORIGIN)
    assert [w[2] for w in m.phases[1].waypoints] == [2.5] and [w[2] for w in m.phases[3].waypoints] == [2.5]


def test_invalid_json(tmp_path: Path) -> None:
    p = tmp_path / "x.plan"
    p.write_text("{ not json")
    with pytest.raises(SpecError, match="invalid JSON at line 1"):
        import_plan(p, ORIGIN)


def test_ardupilot_sprayer_items(plan_file: Path, tmp_path: Path) -> None:
    def to_ardupilot(d):
        items = d["mission"]["items"]
        items[3] = {**items[3], "command": 216, "params": [1, 0, 0, 0, 0, 0, 0]}
        items[5] = {**items[5], "command": 183, "params": [9, 1250, 0, 0, 0, 0, 0]}

    m = import_plan(_mutate(plan_file, tmp_path, to_ardupilot), ORIGIN, nozzle_max_flow_lps=0.1, spray_flow_lps=0.04)
    flows = [p.flow_lps for p in m.phases if isinstance(p, SprayerPhase)]
    assert flows[:2] == pytest.approx([0.04, 0.025])


UTM32 = "EPSG:32632"


def _utm_world() -> GeoFrame:
    """A world on the UTM 32N grid about ORIGIN (grid convergence about -0.68 deg there: 0.97 deg west of the
    central meridian)."""
    cx, cy = Transformer.from_crs("EPSG:4326", UTM32, always_xy=True).transform(ORIGIN.lon, ORIGIN.lat)
    return GeoFrame(ORIGIN.lat, ORIGIN.lon, ORIGIN.alt, crs=UTM32, crs_centre=(cx, cy))


def _spray_mission() -> MissionSpec:
    return MissionSpec(
        name="rt",
        phases=[
            TakeoffPhase(altitude_agl_m=3.0),
            GotoPhase(position_enu=(-2.0, -1.0), altitude_agl_m=3.0, speed_mps=2.0, yaw_deg=30.0),
            SprayPhase(rows="world", height_agl_m=2.0, speed_mps=1.5, flow_lps=0.05),
            HoldPhase(duration_s=2.0),
            LandPhase(),
        ],
        geofence={"polygon_enu": [(-10, -10), (30, -10), (30, 15), (-10, 15)], "max_horizontal_distance_m": 80},
    )


ROWS = [[(0.0, 0.0), (20.0, 0.0)], [(0.0, 2.5), (20.0, 2.5)], [(0.0, 5.0), (20.0, 5.0)]]


def _positions(phases: list) -> list[tuple[float, float, float]]:
    """Every position the phases fly to, in order (x, y, altitude above home)."""
    out = []
    for ph in phases:
        if isinstance(ph, GotoPhase):
            out.append((*ph.position_enu, ph.altitude_agl_m))
        elif isinstance(ph, WaypointsPhase):
            out += [tuple(w) for w in ph.waypoints]
    return out


def _close(a: object, b: object, tol: float) -> bool:
    """Two phase dumps equal, floats within ``tol``."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k], tol) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_close(x, y, tol) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) or isinstance(b, float):
        return a is not None and b is not None and abs(a - b) <= tol
    return a == b


def test_export_is_what_the_px4_bridge_uploads_through_the_worlds_georeference(tmp_path: Path) -> None:
    """The .plan's items are the converter's (phase_items, as the PX4 bridge uploads them: same commands, frames,
    parameters, sprayer switches), with float degrees through the world's CRS grid, and headings from true north."""
    from pyproj import Geod

    from vinecli.mavlink.mission_items import degE7_to_enu
    from vinecli.phase_items import DO_SET_ACTUATOR, PlanContext, phases_to_items

    geo = _utm_world()
    m = _spray_mission()
    plan = export_plan(m, geo, (0.0, 0.0, 0.0), rows_enu=ROWS, nozzle_max_flow_lps=0.1)
    items = plan["mission"]["items"]
    bridge = phases_to_items(m, PlanContext(origin=geo, home_enu=(0.0, 0.0, 0.0), vine_rows_enu=ROWS,
                                            nozzle_max_flow_lps=0.1), sprayer=DO_SET_ACTUATOR).items
    assert [(i["command"], i["frame"]) for i in items] == [(b.command, b.frame) for b in bridge]
    nan_null = lambda v: None if math.isnan(v) else v  # noqa: E731
    assert [i["params"][:4] for i in items] == [[nan_null(p) for p in (b.param1, b.param2, b.param3, b.param4)]
                                                for b in bridge]
    assert [i["params"][6] for i in items] == [b.z for b in bridge]
    to_wgs = Transformer.from_crs(UTM32, "EPSG:4326", always_xy=True)
    for i, b in zip(items, bridge, strict=True):
        if b.x == 0 and b.y == 0:
            assert i["params"][4:6] == [0, 0]
            continue
        e, n = degE7_to_enu(geo, b.x, b.y)  # the bridge's degE7 (1.1 cm steps) back in the world
        lon, lat = to_wgs.transform(e + geo.crs_centre[0], n + geo.crs_centre[1])  # independent of vinecli
        m_lat, m_lon = geo.metres_per_degree
        assert math.hypot((i["params"][4] - lat) * m_lat, (i["params"][5] - lon) * m_lon) < 0.01
    # the goto's yaw (30 deg from the world's x axis) as a heading from true north: the geodesic azimuth
    goto = next(i for i in items if i["command"] == 16)
    a = to_wgs.transform(-2.0 + geo.crs_centre[0], -1.0 + geo.crs_centre[1])
    d = (math.cos(math.radians(30.0)), math.sin(math.radians(30.0)))
    b2 = to_wgs.transform(-2.0 + 10 * d[0] + geo.crs_centre[0], -1.0 + 10 * d[1] + geo.crs_centre[1])
    azimuth = Geod(ellps="WGS84").inv(a[0], a[1], b2[0], b2[1])[0]
    assert goto["params"][3] == pytest.approx(azimuth % 360.0, abs=0.01)
    assert abs(goto["params"][3] - 60.0) > 0.5  # the grid convergence turned it (UTM grid north is not true north)


def test_a_spray_mission_round_trips_through_a_plan_file(tmp_path: Path) -> None:
    """Exported and imported back on a CRS world: the same positions within 1 cm, the same sprayer switches, the
    same take-off, yaw, hold, landing and geofence; a second round trip gives the same phases."""
    geo = _utm_world()
    m = _spray_mission()
    plan = export_plan(m, geo, (0.0, 0.0, 0.0), rows_enu=ROWS, nozzle_max_flow_lps=0.1)
    p = tmp_path / "rt.plan"
    write_plan(p, plan)
    back = import_plan(p, geo, nozzle_max_flow_lps=0.1)
    # the flight: the converter's own phases of the items, flown point for point
    from vinecli.phase_items import DO_SET_ACTUATOR, PlanContext, phases_to_items

    ctx = PlanContext(origin=geo, home_enu=(0.0, 0.0, 0.0), vine_rows_enu=ROWS, nozzle_max_flow_lps=0.1, degrees=True)
    flown = [it for it in phases_to_items(m, ctx, sprayer=DO_SET_ACTUATOR).items if it.command == 16]
    pts = _positions(back.phases)
    assert len(pts) == len(flown)
    for (x, y, h), it in zip(pts, flown, strict=True):
        e, n, _ = geo.geodetic_to_enu(it.x, it.y, geo.alt)
        assert math.hypot(x - e, y - n) < 0.01 and h == pytest.approx(it.z, abs=1e-3)
    flows = [ph.flow_lps for ph in back.phases if isinstance(ph, SprayerPhase)]
    assert flows == pytest.approx([0.0] + [0.05, 0.0] * 3)  # off for the transit, on over each row
    # the row ends: the waypoint where the sprayer goes on, the last one before it goes off (after the transit's off)
    switched_at, last = [], None
    for ph in back.phases:
        if isinstance(ph, (GotoPhase, WaypointsPhase)):
            last = _positions([ph])[-1]
        elif isinstance(ph, SprayerPhase):
            switched_at.append((round(last[0], 2), round(last[1], 2)))
    row_pts = switched_at[1:]
    assert set(row_pts) == {(0.0, 0.0), (20.0, 0.0), (0.0, 2.5), (20.0, 2.5), (0.0, 5.0), (20.0, 5.0)}
    # the row nearest the goto point (-2, -1) first, then boustrophedon: rows flown in alternate directions
    legs = [row_pts[i:i + 2] for i in range(0, 6, 2)]
    assert legs[0][0] == (0.0, 0.0)
    dirs = [math.copysign(1, b[0] - a[0]) for a, b in legs]
    assert dirs[0] == -dirs[1] == dirs[2]
    # headland turns past the row ends (stop turns: 1.5 m/s at 1.5 m/s² run out 0.75 m), the spray height on flat
    xs = [x for x, y, h in pts if y >= -0.01]
    assert min(xs) == pytest.approx(-0.75, abs=1e-3) and max(xs) == pytest.approx(20.75, abs=1e-3)
    assert all(h == pytest.approx(2.0) for x, y, h in pts if y >= -0.01)
    assert isinstance(back.phases[0], TakeoffPhase) and back.phases[0].altitude_agl_m == 3.0
    goto = back.phases[1]
    assert isinstance(goto, GotoPhase) and goto.yaw_deg == pytest.approx(30.0, abs=1e-6) and goto.speed_mps == 2.0
    assert [ph.type for ph in back.phases[-3:]] == ["sprayer", "hold", "land"]  # no goto to where it already is
    assert back.phases[-2].duration_s == 2.0
    assert back.geofence is not None and back.geofence.max_horizontal_distance_m == 80
    assert all(math.dist(a, b) < 0.01 for a, b in zip(back.geofence.polygon_enu, m.geofence.polygon_enu, strict=True))
    # and once more: the imported mission exports to the same items (but a speed item for each waypoints phase,
    # at the speed already set) and imports to the same phases
    again = export_plan(back, geo, (0.0, 0.0, 0.0), nozzle_max_flow_lps=0.1)
    strip = lambda items: [(i["command"], [None if v is None else round(v, 6) for v in i["params"]])  # noqa: E731
                           for i in items if i["command"] != 178]
    assert strip(again["mission"]["items"]) == strip(plan["mission"]["items"])
    write_plan(p2 := tmp_path / "rt2.plan", again)
    twice = import_plan(p2, geo, nozzle_max_flow_lps=0.1)
    assert _close([ph.model_dump() for ph in twice.phases], [ph.model_dump() for ph in back.phases], 1e-3)


def test_imported_mission_names_are_safe(plan_file: Path, tmp_path: Path) -> None:
    """The default name comes from the file name made safe; an unsafe --name is exit 2 (InputError)."""
    from vinecli.errors import InputError

    p = tmp_path / "my survey (v2).plan"
    p.write_bytes(plan_file.read_bytes())
    assert import_plan(p, ORIGIN).name == "my_survey_v2_"
    with pytest.raises(InputError, match="--name"):
        import_plan(p, ORIGIN, name="../escape")
