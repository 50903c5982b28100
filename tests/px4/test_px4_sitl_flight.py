"""Full flights with ``--autopilot px4`` semantics through the real protocol path: the real
run_simulation loop and PyBullet, the real Px4SitlAutopilot (TCP 4560-style server, UDP API
mission client) and the fake PX4 peer (real TCP and UDP sockets on loopback)."""

from __future__ import annotations

import pytest

from tests.px4.fake_px4 import FakePx4
from vinecli.autopilot.base import RunStatus
from vinecli.autopilot.px4_sitl import Px4SitlAutopilot
from vinecli.sim.runner import run_simulation
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
    assert 0.08 < st.hil_gps / st.hil_sensor < 0.12  # 10 Hz GPS at 250 Hz sensors
    assert st.armed_answers > 500 and st.mode_words == {1, 129}
    assert ap.stalls == 0
