"""Refill sorties in the real loop: the tank runs dry mid-pass, the vehicle records the
breakpoint, returns, lands, is refilled (a fresh battery only when the next sortie needs one), takes off,
flies in along the pass at spraying speed and resumes at the breakpoint; the dose joins evenly there."""

from __future__ import annotations

import math

import numpy as np
import pytest
from sim_helpers import mission

from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.missions.deposition_metrics import deposition_metrics
from vinecli.missions.job import sorties
from vinecli.rows.spray_rate import phase_plan
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
    m = mission(_job(), max_duration_s=600, record_rate_hz=50, tank_fill_l=1.0)
    r = run_simulation(world, m, BuiltinAutopilot(), seed=1)
    phase = m.phases[1]
    plan = phase_plan(phase, world.vehicle, [[tuple(p) for p in row] for row in ROWS], (0.0, 0.0),
                      fence_enu=world.geofence.polygon_enu, terrain_bounds=tuple(world.terrain.bounds))
    return world, r, plan


def _dose(r, plan):  # noqa: ANN001, ANN202 - SimResult, RowPlan -> (metrics, profiles)
    return deposition_metrics(r.deposition, [[tuple(p) for p in row] for row in ROWS], 0.6, None,
                              10_000 * 0.05 / (2.0 * plan.flow_width_m), stretches=plan.stretches)


def test_job_completes_every_row_over_sorties(job_run):
    """The passes need (pass length x 0.025 L/m) litres: as many 1 L sorties as that takes, every row dosed."""
    _world, r, plan = job_run
    ts = r.timeseries
    assert r.status.value == "completed", r.detail
    litres = plan.spray_length_m * 0.05 / 2.0
    n = int(np.nanmax(ts["sortie"]))
    assert n == math.ceil(litres)
    table = sorties(ts, [(e.t_us * 1e-6, e.kind, e.data) for e in r.events])
    assert [s["end_reason"] for s in table] == ["tank empty"] * (n - 1) + ["job done"]
    assert all(s["volume_l"] == pytest.approx(1.0, abs=0.01) for s in table[:-1])  # a full tank each time
    # every litre is accounted for: the first fill + the refills - what is left
    delivered = float(np.sum(ts["tank_flow_lps"][:-1] * np.diff(ts["t_s"])))
    assert delivered == pytest.approx(1.0 * n - ts["tank_level_l"][-1], abs=0.005)
    m, _rows = _dose(r, plan)
    assert m["row_coverage_fraction"] >= 0.98 and m["row_rate_error_max"] <= 0.15


def test_service_only_on_the_ground_disarmed_and_in_the_set_time(job_run):
    _world, r, _plan = job_run
    ts = r.timeseries
    t = ts["t_s"]
    n = int(np.nanmax(ts["sortie"]))
    refills = [e for e in r.events if e.kind == "refill"]
    swaps = [e for e in r.events if e.kind == "battery_swap"]
    lands = [e.t_us * 1e-6 for e in r.events if e.kind == "land_detected"]
    assert len(refills) == n - 1
    assert swaps == []  # the 74 Wh pack flies the next sortie with the reserve: no swap needed
    assert not [e for e in r.events if e.kind == "service_refused"]
    for e in refills:
        te = e.t_us * 1e-6
        i = int(np.searchsorted(t, te))
        assert ts["armed"][i] == 0 and ts["on_ground"][i] == 1
        assert ts["tank_level_l"][min(i + 1, len(t) - 1)] == pytest.approx(1.0, abs=1e-3)
        landed = max(x for x in lands if x <= te)
        assert te - landed == pytest.approx(10.0, abs=0.1)  # the refill's ground time


def test_resume_at_the_breakpoint_at_spraying_speed_and_the_dose_joins_evenly(job_run):
    """After a refill the vehicle flies in along the pass and the liquid starts at the breakpoint (the section
    opens the pump's lag before it) with the vehicle at spraying speed: no hover start, no gap, no overlap."""
    _world, r, plan = job_run
    ts = r.timeseries
    ends = [e for e in r.events if e.kind == "sortie" and e.data.get("event") == "end"]
    assert ends
    speed = np.hypot(ts["vel_enu_x_mps"], ts["vel_enu_y_mps"])
    for e in ends:
        bx, by, _ = e.data["breakpoint_enu"]
        n = e.data["sortie"]
        on = (ts["sortie"] == n + 1) & (ts["tank_flow_lps"] > 0)
        i = int(np.flatnonzero(on)[0])
        d = math.hypot(ts["pos_enu_x_m"][i] - bx, ts["pos_enu_y_m"][i] - by)
        assert d <= 2.0 * 0.3 + 0.5, d  # the lead (speed x tau_up) and the GNSS-grade breakpoint
        assert speed[i] >= 1.6  # in at spraying speed (2 m/s), not from a hover
    m, _rows = _dose(r, plan)
    assert m["dose_window_ratio_max"] <= 1.3 and m["dose_window_ratio_min"] >= 0.6


def test_a_sortie_closes_its_sections_before_the_tank_runs_dry(job_run):
    """The sortie ends with the pump's run-down (flow x tau_down) still in the tank and closes the sections itself, so
    its deposit ends in the pump's fall that the next sortie's led opening complements: the metre either side of each
    breakpoint within 15 % of the row's mean (run dry, the flow stopped at once and the led opening sprayed 0.4 m over
    what the sortie had dosed: 1.26-1.30x at the ci job's breakpoints)."""
    _world, r, plan = job_run
    ts = r.timeseries
    _m, rows = _dose(r, plan)
    ends = [e for e in r.events if e.kind == "sortie" and e.data.get("event") == "end" and "breakpoint_enu" in e.data]
    assert ends
    for e in ends:
        t = e.t_us * 1e-6
        left = float(np.interp(t, ts["t_s"], ts["tank_level_l"]))
        assert 0.0 < left <= 0.05 * 0.15 + 1e-4  # the run-down, closed by the sortie, not run dry
        bx, by, _ = e.data["breakpoint_enu"]
        k = min(range(len(ROWS)), key=lambda j: abs(ROWS[j][0][0] - bx))
        rate = np.asarray(rows[k]["rate_lpha"], dtype=float)
        i = int(by / 0.5)
        near = [rate[j:j + 2].mean() / rows[k]["mean_rate_lpha"] for j in range(i - 2, i + 1) if 0 <= j < rate.size - 1]
        assert all(abs(w - 1.0) <= 0.15 for w in near), (e.data["breakpoint_s_m"], near)


def _small_pack(capacity_wh: float):
    from vinecli.vehicle import load_vehicle

    v = load_vehicle("x500-sprayer")
    return v.model_copy(update={"battery": v.battery.model_copy(update={"capacity_wh": capacity_wh, "low_soc": 0.5})})


def test_low_battery_ends_a_sortie(flat_world_dir):
    """A 20 Wh pack that must land with half of it: the sortie comes home on energy before the tank is empty,
    the crew swaps the battery (the next sortie needs it), the job still completes."""
    from vinecli.world import load_world

    v = _small_pack(20.0)
    r = run_simulation(load_world(flat_world_dir), mission(_job(0.03), max_duration_s=900, record_rate_hz=20,
                                                           tank_fill_l=1.0), BuiltinAutopilot(), seed=2, vehicle=v)
    reasons = [e.data["reason"] for e in r.events if e.kind == "sortie" and e.data.get("event") == "end"]
    assert any(x.startswith("battery") for x in reasons), reasons
    assert r.status.value == "completed", r.detail
    assert [e for e in r.events if e.kind == "battery_swap"]
    assert np.nanmin(r.timeseries["battery_soc"]) > v.battery.critical_soc  # never into the failsafe levels


def test_a_job_that_cannot_progress_is_aborted(flat_world_dir):
    """A 3 Wh pack must turn home before it reaches the breakpoint again: the job is aborted with 'no progress'
    instead of flying the same transit until the time limit. (Its return dips into the emergency reserve, where
    the battery failsafe would land it first: the failsafe levels are set to 0 here so that the job's own guard
    is what stops it.)"""
    from vinecli.world import load_world

    v = _small_pack(3.0)
    v = v.model_copy(update={"battery": v.battery.model_copy(update={"critical_soc": 0.0, "emergency_soc": 0.0})})
    r = run_simulation(load_world(flat_world_dir), mission(_job(0.03), max_duration_s=900, record_rate_hz=10,
                                                           tank_fill_l=1.0), BuiltinAutopilot(), seed=2,
                       vehicle=v)
    ends = [e.data for e in r.events if e.kind == "sortie" and e.data.get("event") == "end"]
    assert ends[-1]["reason"].startswith("no progress") and len(ends) <= 10
    assert r.status.value == "aborted" and "not sprayed" in r.detail
    assert r.sim_time_s < 300


def test_crew_refuses_a_flying_vehicle():
    from vinecli.flight.tank import Tank
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
    """A 3 Wh pack with no reserve asked of the sortie and PX4's battery failsafes: the critical level comes while
    the sortie's return is under way (recorded, the return goes on), the emergency level lands the vehicle where
    it is and ends the run 'failsafe' (the job was not finished)."""
    from vinecli.world import load_world

    r = run_simulation(load_world(flat_world_dir), mission(_job(0.03, reserve_soc=0.0), max_duration_s=900,
                                                           record_rate_hz=10, tank_fill_l=1.0),
                       BuiltinAutopilot(), seed=2, vehicle=_small_pack(3.0))
    fs = [(e.data["cause"], e.data["action"]) for e in r.events if e.kind == "failsafe"]
    assert fs == [("low_battery", "rtl"), ("low_battery", "land")]
    assert r.status.value == "failsafe" and "below the emergency level" in r.detail and r.sim_time_s < 60
