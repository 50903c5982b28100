"""QGroundControl .plan import/export (tests/data/vineyard_spray.plan: QGC-style plan with a survey)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from vinecli.errors import SpecError
from vinecli.geo import GeoOrigin
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
    ],
)
def test_import_errors_name_the_item(plan_file: Path, tmp_path: Path, mutate, needle: str) -> None:
    p = _mutate(plan_file, tmp_path, mutate)
    with pytest.raises(SpecError) as ei:
        import_plan(p, ORIGIN)
    assert needle in str(ei.value) and "bad.plan" in str(ei.value)


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


def test_round_trip_export_import(tmp_path: Path) -> None:
    rows = [[(0.0, 0.0), (20.0, 0.0)], [(0.0, 2.5), (20.0, 2.5)], [(0.0, 5.0), (20.0, 5.0)]]
    m = MissionSpec(
        name="rt",
        phases=[
            TakeoffPhase(altitude_agl_m=3.0),
            GotoPhase(position_enu=(-2.0, -1.0), altitude_agl_m=3.0, speed_mps=2.0),
            SprayPhase(rows="world", height_agl_m=2.0, speed_mps=1.5, flow_lps=0.05),
            HoldPhase(duration_s=2.0),
            LandPhase(),
        ],
        geofence={"polygon_enu": [(-10, -10), (30, -10), (30, 15), (-10, 15)], "max_horizontal_distance_m": 80},
    )
    plan = export_plan(m, ORIGIN, (0.0, 0.0, 0.0), rows_enu=rows, nozzle_max_flow_lps=0.1)
    assert plan["fileType"] == "Plan" and plan["mission"]["firmwareType"] == 12
    cmds = [it["command"] for it in plan["mission"]["items"]]
    assert cmds.count(187) == 6 and cmds[0] == 22 and cmds[-1] == 21
    p = tmp_path / "rt.plan"
    write_plan(p, plan)
    back = import_plan(p, ORIGIN, nozzle_max_flow_lps=0.1)
    # spray rows come back as waypoints with sprayer switches along each row
    wps = [w for ph in back.phases if isinstance(ph, WaypointsPhase) for w in ph.waypoints]
    flows = [ph.flow_lps for ph in back.phases if isinstance(ph, SprayerPhase)]
    assert flows == pytest.approx([0.05, 0.0] * 3)
    assert all(h == pytest.approx(2.0) for x, y, h in wps if y >= -0.01)  # flat: the spray height throughout
    # the row ends: the waypoint where the sprayer goes on, the last one before it goes off
    row_pts, last = [], None
    for ph in back.phases:
        if isinstance(ph, WaypointsPhase):
            last = ph.waypoints[-1]
        elif isinstance(ph, SprayerPhase) and last is not None:
            row_pts.append((round(last[0], 2), round(last[1], 2)))
    assert set(row_pts) == {(0.0, 0.0), (20.0, 0.0), (0.0, 2.5), (20.0, 2.5), (0.0, 5.0), (20.0, 5.0)}
    # the row nearest the goto point (-2, -1) first, then boustrophedon: rows flown in alternate directions
    legs = [row_pts[i:i + 2] for i in range(0, 6, 2)]
    assert legs[0][0] == (0.0, 0.0)
    dirs = [math.copysign(1, b[0] - a[0]) for a, b in legs]
    assert dirs[0] == -dirs[1] == dirs[2]
    # headland turns past the row ends (stop turns: 1.5 m/s at 1.5 m/s² run out 0.75 m)
    xs = [x for x, y, h in wps if y >= -0.01]
    assert min(xs) == pytest.approx(-0.75, abs=1e-3) and max(xs) == pytest.approx(20.75, abs=1e-3)
    assert isinstance(back.phases[0], TakeoffPhase) and back.phases[0].altitude_agl_m == 3.0
    assert isinstance(back.phases[-1], LandPhase)
    assert back.geofence is not None and back.geofence.max_horizontal_distance_m == 80
    assert back.geofence.polygon_enu[2] == pytest.approx((30.0, 15.0), abs=2e-3)
    # export of the imported mission gives the same items again
    again = export_plan(back, ORIGIN, (0.0, 0.0, 0.0), nozzle_max_flow_lps=0.1)
    strip = lambda items: [(i["command"], [None if v is None else round(v, 6) for v in i["params"]]) for i in items]  # noqa: E731
    a = [x for x in strip(plan["mission"]["items"]) if x[0] != 178]
    b = [x for x in strip(again["mission"]["items"]) if x[0] != 178]
    assert a == b


def test_imported_mission_names_are_safe(plan_file: Path, tmp_path: Path) -> None:
    """The default name comes from the file name made safe; an unsafe --name is exit 2 (InputError)."""
    from vinecli.errors import InputError

    p = tmp_path / "my survey (v2).plan"
    p.write_bytes(plan_file.read_bytes())
    assert import_plan(p, ORIGIN).name == "my_survey_v2_"
    with pytest.raises(InputError, match="--name"):
        import_plan(p, ORIGIN, name="../escape")
