"""The PX4 link keeps its footing, and a PX4 that stops early ends the run early. 1.5 kB of garbage on the simulator's TCP link swallows one of
PX4's answers (PX4 answers each HIL_SENSOR once); the lockstep notices the garbage, takes that step with the last
outputs (a stall and a resynchronisation, in the metrics and the events) and PX4 answers the next one: the flight
goes on to its end instead of waiting 30 s and ending "PX4 stopped answering". Real sockets, the fake PX4 peer,
vinecli's lockstep as ``run mission`` uses it (no step timeout)."""

from __future__ import annotations

import time

import pytest

from tests.sitl.px4.fake_px4 import FakePx4
from tests.sitl.px4.test_px4_sitl_flight import takeoff_hover_land
from vinecli.autopilot.base import RunStatus
from vinecli.sim.runner import run_simulation
from vinecli.sitl.px4.backend import Px4SitlAutopilot

pytestmark = pytest.mark.timeout(240)


def fly_against_fake(world, ports, mission=None, hang_timeout_s: float = 30.0, **fake_kw):
    """A run of ``mission`` (default: take off, hover, land) by the real Px4SitlAutopilot against the fake PX4 built
    with ``fake_kw`` (its faults): (result, fake, wall seconds)."""
    fake = FakePx4(world.vehicle, world.origin, sim_port=ports["sim"], api_local_port=ports["px4"],
                   api_remote_port=ports["api"], **fake_kw).start()
    ap = Px4SitlAutopilot(port=ports["sim"], api_port=ports["api"], px4_api_port=ports["px4"], connect_timeout_s=10,
                          health_timeout_s=20, hang_timeout_s=hang_timeout_s)
    t0 = time.monotonic()
    try:
        res = run_simulation(world, mission if mission is not None else takeoff_hover_land(), ap, seed=3)
    finally:
        ap.close()
        fake.stop()
    return res, fake, time.monotonic() - t0


def test_garbage_on_the_simulator_link_is_resynchronised(world, ports):
    res, fake, took = fly_against_fake(world, ports, garbage_at_s=4.0)  # no step timeout, a 30 s hang limit
    assert fake.garbage_sent > 1500
    assert res.status is RunStatus.COMPLETED, (res.status, res.detail)
    assert res.metrics["px4_resyncs"] >= 1 and res.metrics["px4_stalls"] >= res.metrics["px4_resyncs"]
    assert any("garbage on the simulator link" in e.message for e in res.events)
    assert took < 120, f"{took:.0f} s: the run waited on the lost answer"


def test_a_px4_that_lands_and_disarms_before_reporting_the_last_item_ends_the_run_at_once(world, ports):
    """It used to wait for ``max_duration_s``; now the run ends ``aborted`` 3 s (simulated) after the disarm, naming
    the item PX4 was at."""
    mission = takeoff_hover_land()
    res, _fake, _took = fly_against_fake(world, ports, mission, silent_from_item=2)
    assert res.status is RunStatus.ABORTED, (res.status, res.detail)
    assert "landed and disarmed before the mission's end: at mission item 1 of" in res.detail
    disarm = next(e.t_us for e in res.events if e.kind == "arming" and e.message == "disarmed") * 1e-6
    assert res.sim_time_s < disarm + 5.0 < mission.max_duration_s
