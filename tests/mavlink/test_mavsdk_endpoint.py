"""End to end with MAVSDK-Python 4.x (a real client no one here wrote) against the built-in
autopilot's MAVLink endpoint: connect, health, arm, takeoff, upload and fly a spray mission with
DO_SET_ACTUATOR (MissionRaw), land. Real UDP on loopback, the real simulation loop in a thread."""

from __future__ import annotations

import asyncio
import math
import socket

import pytest
from loopback_world import free_port

from tests.sitl.px4.sim_thread import SimThread
from vinecli.autopilot.base import RunStatus
from vinecli.autopilot.mavlink_vehicle import MavlinkControlledAutopilot
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.mission_items import enu_to_degE7
from vinecli.specs.mission import MissionSpec

pytestmark = pytest.mark.timeout(180)

RUN = MissionSpec.model_validate({"name": "mavsdk-run", "max_duration_s": 300.0,
                                  "phases": [{"type": "takeoff", "altitude_agl_m": 2.5}, {"type": "land"}]})


async def until(coro_fn, pred, timeout: float, what: str):
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    while loop.time() < deadline:
        v = await coro_fn()
        if pred(v):
            return v
        await asyncio.sleep(0.1)
    raise AssertionError(f"timed out waiting for {what}")


async def fly_with_mavsdk(port: int, origin) -> dict[str, object]:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
    from mavsdk.plugins.mission_raw import MissionItem

    out: dict[str, object] = {}
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        await sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
        drone = await sdk.first_autopilot(15.0)
        assert drone is not None, "MAVSDK found no autopilot"
        from mavsdk.asyncio import Autopilot

        out["autopilot_type"] = Autopilot(int(await drone.autopilot_type()))
        tel, act, mis = TelemetryAsync(drone), ActionAsync(drone), MissionRawAsync(drone)
        await until(tel.health_all_ok, bool, 30, "health all ok")
        health = await until(tel.health, lambda h: h.is_armable, 30, "armable")
        out["health"] = health
        out["takeoff_alt"] = await act.get_takeoff_altitude()
        await act.arm()
        await until(tel.armed, bool, 5, "armed")
        await act.takeoff()
        pos = await until(tel.position, lambda p: p.relative_altitude_m > 2.2, 30, "takeoff altitude")
        out["climb_alt"] = pos.relative_altitude_m
        # spray mission: waypoint to the row start, sprayer on (DO_SET_ACTUATOR set 1 = 0.6), along the row,
        # sprayer off, land -- raw MISSION_ITEM_INTs because the Mission plugin has no actuator items
        def wp(x: float, y: float, z: float, cmd: int = M.CMD_NAV_WAYPOINT) -> tuple:
            lat, lon = enu_to_degE7(origin, x, y)
            return (M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, cmd, 0.0, 0.5, 0.0, math.nan, lat, lon, z)

        raw = [wp(3.0, 0.0, 2.5),
               (M.MAV_FRAME_MISSION, M.CMD_DO_SET_ACTUATOR, 0.6, math.nan, math.nan, math.nan, 0, 0, 0.0),
               (M.MAV_FRAME_MISSION, M.CMD_DO_CHANGE_SPEED, 1.0, 1.5, -1.0, 0.0, 0, 0, 0.0),
               wp(3.0, 6.0, 2.5),
               (M.MAV_FRAME_MISSION, M.CMD_DO_SET_ACTUATOR, 0.0, math.nan, math.nan, math.nan, 0, 0, 0.0),
               wp(3.0, 6.0, 0.0, M.CMD_NAV_LAND)]
        items = [MissionItem(seq=i, frame=f, command=c, current=int(i == 0), autocontinue=1, param1=p1, param2=p2,
                             param3=p3, param4=p4, x=x, y=y, z=z, mission_type=0)
                 for i, (f, c, p1, p2, p3, p4, x, y, z) in enumerate(raw)]
        await mis.upload_mission(items)
        down = await mis.download_mission()
        out["downloaded"] = [(it.command, it.x, it.y) for it in down]
        await mis.start_mission()
        await until(tel.in_air, lambda a: not a, 90, "landing")
        await until(tel.armed, lambda a: not a, 10, "disarmed after landing")
        out["final_pos"] = await tel.position()
    finally:
        sdk.destroy()
    return out


def test_mavsdk_flies_a_spray_mission(world):
    port = free_port(socket.SOCK_DGRAM)
    ap = MavlinkControlledAutopilot(url=f"udp:127.0.0.1:{port}", local_port=free_port(socket.SOCK_DGRAM))
    sim = SimThread(world, RUN, ap).start()
    try:
        out = asyncio.run(asyncio.wait_for(fly_with_mavsdk(port, world.origin), 150))
    finally:
        sim.stop()
    res = sim.join(30)
    assert out["autopilot_type"].name == "PX4"  # MAVSDK applies its PX4 quirks to this vehicle
    h = out["health"]
    assert h.is_global_position_ok and h.is_home_position_ok and h.is_gyrometer_calibration_ok
    assert out["takeoff_alt"] == pytest.approx(2.5)  # MIS_TAKEOFF_ALT from the run's takeoff phase
    assert [c for c, _x, _y in out["downloaded"]] == [16, 187, 178, 16, 187, 21]
    assert res.status is RunStatus.COMPLETED, (res.status, res.detail)
    ts = res.timeseries
    flow = ts["tank_flow_lps"]
    assert flow.max() == pytest.approx(0.06)  # 0.6 x 0.1 L/s nozzle
    x, y = ts["pos_enu_x_m"], ts["pos_enu_y_m"]
    on = flow > 0
    assert abs(x[on] - 3.0).max() < 0.8 and y[on].min() > -0.8 and y[on].max() < 6.8  # sprayed along the row
    assert abs(x[-1] - 3.0) < 0.8 and abs(y[-1] - 6.0) < 0.8  # landed at the row end
    kinds = {e.kind for e in res.events}
    assert {"liftoff", "touchdown", "sprayer", "arming"} <= kinds
