"""Refill sorties (issue 13) in the real loop: the tank runs dry mid-row, the vehicle records the
breakpoint, returns, lands, is refilled with a fresh battery, takes off and resumes there."""

from __future__ import annotations

import math

import numpy as np
import pytest
from sim_helpers import mission

from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.missions.job import rows_sprayed, sorties
from vinecli.sim.loop import serve_ground_request
from vinecli.sim.runner import run_simulation
from vinecli.specs.mission import SprayPhase
from vinecli.types import Event, ServiceRequest

ROWS = [[[x, 0.0], [x, 20.0]] for x in (3.0, 4.0, 5.0, 6.0)]  # 80 m of rows, 1 m apart


def _job(flow: float = 0.05, **refill: object) -> list[dict[str, object]]:
    return [{"type": "takeoff", "altitude_agl_m": 2.0},
            {"type": "spray", "rows": ROWS, "height_agl_m": 2.0, "speed_mps": 2.0, "flow_lps": flow,
             "timeout_s": 2000, "refill": {"time_s": 10, **refill}},
            {"type": "rtl"}]


@pytest.fixture(scope="module")
def job_run(flat_world_dir):
    from vinecli.world import load_world

    world = load_world(flat_world_dir)
    r = run_simulation(world, mission(_job(), max_duration_s=600, record_rate_hz=50, tank_fill_l=1.0),
                       BuiltinAutopilot(), seed=1)
    return world, r


def test_job_completes_every_row_over_three_sorties(job_run):
    """80 m of rows at 0.025 L/m need 2 L: three 1 L sorties, every row sprayed."""
    _world, r = job_run
    ts = r.timeseries
    assert r.status.value == "completed", r.detail
    assert np.nanmax(ts["sortie"]) == 3
    frac, length = rows_sprayed(ts, [[tuple(p) for p in row] for row in ROWS])
    assert frac >= 0.98 and length == pytest.approx(80.0 * frac)
    table = sorties(ts, [(e.t_us * 1e-6, e.kind, e.data) for e in r.events])
    assert [s["end_reason"] for s in table] == ["tank empty", "tank empty", "job done"]
    assert all(s["volume_l"] == pytest.approx(1.0, abs=0.01) for s in table[:2])  # a full tank each time
    # every litre is accounted for: the first fill + two refills - what is left (rows hold their flow)
    delivered = float(np.sum(ts["tank_flow_lps"][:-1] * np.diff(ts["t_s"])))
    assert delivered == pytest.approx(1.0 + 2 * 1.0 - ts["tank_level_l"][-1], abs=0.005)
    assert delivered >= 2.0  # 80 m at 0.025 L/m at least (more where the vehicle slows at the row ends)


def test_service_only_on_the_ground_disarmed_and_in_the_set_time(job_run):
    _world, r = job_run
    ts = r.timeseries
    t = ts["t_s"]
    refills = [e for e in r.events if e.kind == "refill"]
    swaps = [e for e in r.events if e.kind == "battery_swap"]
    lands = [e.t_us * 1e-6 for e in r.events if e.kind == "land_detected"]
    assert len(refills) == 2 and len(swaps) == 2
    assert not [e for e in r.events if e.kind == "service_refused"]
    for e in refills:
        te = e.t_us * 1e-6
        i = int(np.searchsorted(t, te))
        assert ts["armed"][i] == 0 and ts["on_ground"][i] == 1
        assert ts["tank_level_l"][min(i + 1, len(t) - 1)] == pytest.approx(1.0, abs=1e-3)
        landed = max(x for x in lands if x <= te)
        assert te - landed == pytest.approx(10.0, abs=0.1)  # the refill's ground time
    for e in swaps:
        assert e.data["soc_before"] < 1.0 and e.data["soc"] == 1.0


def test_resume_at_the_breakpoint(job_run):
    """The first liquid after a refill lands within the overlap (1 m) + the spray gate (0.7 m) of the
    breakpoint, and the row between them is not skipped."""
    _world, r = job_run
    ts = r.timeseries
    ends = [e for e in r.events if e.kind == "sortie" and e.data.get("event") == "end"]
    assert len(ends) == 2
    for e in ends:
        bx, by, _ = e.data["breakpoint_enu"]
        n = e.data["sortie"]
        on = (ts["sortie"] == n + 1) & (ts["tank_flow_lps"] > 0)
        i = int(np.flatnonzero(on)[0])
        d = math.hypot(ts["pos_enu_x_m"][i] - bx, ts["pos_enu_y_m"][i] - by)
        assert d <= 1.0 + 0.7 + 0.2, d


def _small_pack(capacity_wh: float):
    from vinecli.vehicle import load_vehicle

    v = load_vehicle("x500-sprayer")
    return v.model_copy(update={"battery": v.battery.model_copy(update={"capacity_wh": capacity_wh, "low_soc": 0.5})})


def test_low_battery_ends_a_sortie(flat_world_dir):
    """An 8 Wh pack with a 50 % return threshold runs low before the tank (0.03 L/s) is empty: the
    sortie ends for the battery, the crew swaps it, the job still completes."""
    from vinecli.world import load_world

    v = _small_pack(8.0)
    r = run_simulation(load_world(flat_world_dir), mission(_job(0.03), max_duration_s=900, record_rate_hz=20,
                                                           tank_fill_l=1.0), BuiltinAutopilot(), seed=2, vehicle=v)
    reasons = [e.data["reason"] for e in r.events if e.kind == "sortie" and e.data.get("event") == "end"]
    assert any(x.startswith("battery") for x in reasons), reasons
    assert r.status.value == "completed", r.detail
    assert rows_sprayed(r.timeseries, [[tuple(p) for p in row] for row in ROWS])[0] >= 0.98
    assert np.nanmin(r.timeseries["battery_soc"]) > v.battery.emergency_soc  # never into the emergency reserve


def test_a_job_that_cannot_progress_is_aborted(flat_world_dir):
    """A 3 Wh pack is at its return threshold before it reaches the breakpoint again: the job stops
    with 'no progress' instead of flying the same transit until the time limit. (Its return dips
    into the emergency reserve, where the battery failsafe would land it first: the failsafe
    levels are set to 0 here so that the job's own guard is what stops it.)"""
    from vinecli.world import load_world

    v = _small_pack(3.0)
    v = v.model_copy(update={"battery": v.battery.model_copy(update={"critical_soc": 0.0, "emergency_soc": 0.0})})
    r = run_simulation(load_world(flat_world_dir), mission(_job(0.03), max_duration_s=900, record_rate_hz=10,
                                                           tank_fill_l=1.0), BuiltinAutopilot(), seed=2,
                       vehicle=v)
    ends = [e.data for e in r.events if e.kind == "sortie" and e.data.get("event") == "end"]
    assert ends[-1]["reason"].startswith("no progress") and len(ends) <= 10
    assert r.sim_time_s < 300


def test_crew_refuses_a_flying_vehicle():
    from vinecli.physics.tank import Tank
    from vinecli.vehicle import load_vehicle

    tank = Tank(load_vehicle("x500-sprayer").tank, 0.0)
    events: list[Event] = []
    serve_ground_request(ServiceRequest(1.0, True), False, False, tank, None, 0, events, True)
    assert tank.level_l == 0.0 and events[-1].kind == "service_refused"
    serve_ground_request(ServiceRequest(1.0, True), False, True, tank, None, 0, events, True)
    assert tank.level_l == pytest.approx(1.0) and events[-1].kind == "refill"


def test_refill_needs_rows_done():
    with pytest.raises(ValueError, match="rows_done"):
        SprayPhase.model_validate({"type": "spray", "flow_lps": 0.02, "until": "empty", "refill": {}})


def test_a_job_whose_return_reaches_the_emergency_reserve_lands_there(flat_world_dir):
    """The same 3 Wh pack with PX4's battery failsafes: the critical level comes while the sortie's
    return is under way (recorded, the return goes on), the emergency level lands the vehicle where
    it is and ends the job."""
    from vinecli.world import load_world

    r = run_simulation(load_world(flat_world_dir), mission(_job(0.03), max_duration_s=900, record_rate_hz=10,
                                                           tank_fill_l=1.0), BuiltinAutopilot(), seed=2,
                       vehicle=_small_pack(3.0))
    fs = [(e.data["cause"], e.data["action"]) for e in r.events if e.kind == "failsafe"]
    assert fs == [("low_battery", "rtl"), ("low_battery", "land")]
    assert r.status.value == "completed" and "below the emergency level" in r.detail and r.sim_time_s < 60

