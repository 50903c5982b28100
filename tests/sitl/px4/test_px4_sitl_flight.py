"""Full flights with ``--autopilot px4`` semantics through the real protocol path: the real
run_simulation loop and PyBullet, the real Px4SitlAutopilot (TCP 4560-style server, UDP API
mission client) and the fake PX4 peer (real TCP and UDP sockets on loopback)."""

from __future__ import annotations

import pytest

from tests.sitl.px4.fake_px4 import FakePx4
from vinecli.autopilot.base import RunStatus
from vinecli.sim.runner import run_simulation
from vinecli.sitl.px4.backend import Px4SitlAutopilot
from vinecli.specs.mission import MissionSpec

pytestmark = pytest.mark.timeout(240)


def fly(world, mission: MissionSpec, ports: dict[str, int], **fake_kw):
    fake = FakePx4(world.vehicle, world.origin, sim_port=ports["sim"], api_local_port=ports["px4"],
                   api_remote_port=ports["api"], **fake_kw).start()
    ap = Px4SitlAutopilot(port=ports["sim"], api_port=ports["api"], px4_api_port=ports["px4"], connect_timeout_s=10,
                          step_timeout_s=0.5, max_stalls=10, health_timeout_s=20)
    try:
        res = run_simulation(world, mission, ap, seed=3)
    finally:
        ap.close()
        fake.stop()
    return res, ap, fake


def takeoff_hover_land(wind: dict | None = None) -> MissionSpec:
    d = {"name": "px4-hover", "autopilot": "px4", "max_duration_s": 60.0,
         "phases": [{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "hold", "duration_s": 4.0}, {"type": "land"}]}
    if wind:
        d["wind"] = wind
    return MissionSpec.model_validate(d)


def test_takeoff_hover_land_through_px4_protocol(world, ports):
    res, ap, fake = fly(world, takeoff_hover_land(), ports)
    assert fake.error is None, fake.error
    assert fake.violations == []
    assert res.status is RunStatus.COMPLETED, (res.status, res.detail)
    z = res.timeseries["pos_enu_z_m"]
    z0 = world.spawn_enu[2]
    assert 2.4 < z.max() - z0 < 3.6
    assert abs(z[-1] - z0) < 0.1  # back on the ground
    kinds = [e.kind for e in res.events]
    for k in ("px4", "mission_uploaded", "px4_health", "arming", "mission_start", "mission_item_reached", "liftoff", "touchdown"):
        assert k in kinds, k
    st = fake.stats
    assert st.hil_sensor == st.hil_state > 1000
    assert 0.035 < st.hil_gps / st.hil_sensor < 0.045  # 10 Hz GPS, 250 Hz sensors
    assert st.armed_answers > 500 and st.mode_words == {1, 129}
    assert ap.stalls == 0


def test_gust_hover_through_px4_protocol(world, ports):
    # a 6 m/s 1-cosine gust towards east while hovering (boot and arming take ~1 s of sim time)
    gust = {"law": {"type": "gust", "peak_mps": 6.0, "start_s": 5.0, "duration_s": 4.0, "heading_deg": 90.0}}
    mission = MissionSpec.model_validate({
        "name": "px4-gust-hover", "autopilot": "px4", "max_duration_s": 60.0, "wind": gust,
        "phases": [{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "hold", "duration_s": 8.0}, {"type": "land"}]})
    res, ap, fake = fly(world, mission, ports)
    assert fake.error is None and fake.violations == []
    assert res.status is RunStatus.COMPLETED, (res.status, res.detail)
    ts = res.timeseries
    t = ts["t_s"]
    wind_x = ts["wind_enu_x_mps"]
    assert wind_x.max() > 5.5  # the gust was applied (east, 90° heading)
    gust_win = (t > 5.0) & (t < 9.5)
    dx = abs(ts["pos_enu_x_m"][gust_win]).max()
    assert 0.05 < dx < 2.5  # pushed, and held within a couple of metres by PX4-side control
    assert abs(ts["pos_enu_z_m"][-1] - world.spawn_enu[2]) < 0.1


def test_spray_rows_drive_the_tank_through_do_set_actuator(tmp_path, ports):
    from loopback_world import flat_world

    w = flat_world(tmp_path, rows=[[(2.0, -3.0), (2.0, 3.0)], [(4.0, -3.0), (4.0, 3.0)]])
    mission = MissionSpec.model_validate({
        "name": "px4-spray", "autopilot": "px4", "max_duration_s": 90.0,
        "phases": [{"type": "takeoff", "altitude_agl_m": 2.5},
                   {"type": "spray", "height_agl_m": 2.0, "speed_mps": 1.5, "flow_lps": 0.05},
                   {"type": "land"}],
        "geofence": {"polygon_enu": [[-20, -20], [20, -20], [20, 20], [-20, 20]], "action": "rtl", "max_altitude_agl_m": 25}})
    res, ap, fake = fly(w, mission, ports)
    ep = fake.ap.endpoint  # what the (fake) PX4 received on its API link
    assert [it.command for it in ep.missions[1]] == [5001] * 4 and all(it.param1 == 4 for it in ep.missions[1])
    assert ep.params["GF_ACTION"] == 3 and ep.params["GF_MAX_VER_DIST"] == 25.0 and ep.params["PWM_MAIN_FUNC9"] == 301
    assert ep.params["MIS_TAKEOFF_ALT"] == 2.5
    assert 187 in [it.command for it in ep.missions[0]]
    assert fake.error is None and fake.violations == []
    assert res.status is RunStatus.COMPLETED, (res.status, res.detail)
    ts = res.timeseries
    flow = ts["tank_flow_lps"]
    assert abs(flow.max() - 0.05) < 1e-6  # u = 0.05 / 0.1 on the sprayer channel -> 0.05 L/s
    assert fake.stats.spray_u_max == pytest.approx(0.5)
    spraying = flow > 0.01 * 0.05  # (the closing valve's exponential tail aside)
    assert abs(ts["pos_enu_x_m"][spraying] - 2.0).min() < 0.5  # sprays over the rows...
    # ...run on past the row ends by the spray footprint and the pump's ramp (THE spray plan the built-in flies),
    # and not in the turns beyond
    from vinecli.rows.spray_rate import spray_pattern

    v = w.vehicle
    pat = spray_pattern(v, 2.0, 1.5)
    run_on = pat.footprint_radius_m + pat.along_offset_m + 1.5 * max(v.sprayer.pump.tau_up_s, v.sprayer.pump.tau_down_s)
    assert (abs(ts["pos_enu_y_m"][spraying]) < 3.0 + run_on + 0.6).all()
    assert (abs(ts["pos_enu_y_m"][~spraying & (ts["pos_enu_z_m"] > 1.5)]) > 3.0 + run_on - 0.6).any()
    assert ts["tank_level_l"][-1] < ts["tank_level_l"][0] - 0.1


def test_px4_never_connects_is_refused_quickly(world, ports):
    """No PX4 where the user said one runs: FirmwareUnreachable (exit 2) naming the port and the start command,
    within the connect timeout, and nothing left listening."""
    import socket
    import time

    from vinecli.errors import FirmwareUnreachable

    ap = Px4SitlAutopilot(port=ports["sim"], api_port=ports["api"], px4_api_port=ports["px4"], connect_timeout_s=0.5)
    t0 = time.monotonic()
    try:
        with pytest.raises(FirmwareUnreachable) as err:
            run_simulation(world, takeoff_hover_land(), ap, seed=1)
    finally:
        ap.close()
    assert time.monotonic() - t0 < 10 and err.value.exit_code == 2
    msg = str(err.value)
    assert f"127.0.0.1:{ports['sim']}" in msg and "did not connect" in msg
    assert "PX4_SIM_MODEL=none_iris" in msg and "px4 -d -i 0" in msg
    with socket.socket() as s:  # the simulator port was released
        s.bind(("127.0.0.1", ports["sim"]))


def test_px4_going_silent_mid_run_is_an_error(world, ports):
    res, ap, _fake = fly(world, takeoff_hover_land(), ports, silent_after_s=3.0)
    assert res.status is RunStatus.ERROR
    assert "stopped answering" in res.detail and "10 consecutive steps" in res.detail
    assert res.sim_time_s > 3.0 and any(e.kind == "autopilot_error" for e in res.events)
    assert res.metrics["px4_stalls"] >= 10  # the lockstep counters reach the run's metrics


def test_arming_rejected_reports_px4_reason(world, ports):
    res, _ap, _fake = fly(world, takeoff_hover_land(), ports, reject_arm="Preflight Fail: Compass Sensor 0 missing")
    assert res.status is RunStatus.ERROR
    assert "PX4 rejected arming: DENIED" in res.detail and "Preflight Fail: Compass Sensor 0 missing" in res.detail
