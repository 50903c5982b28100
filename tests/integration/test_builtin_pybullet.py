"""The built-in autopilot through the real simulation loop (PyBullet, physics models, sensors)
on worlds/flat.yaml: takeoff/hold/land, and a spray pass over two rows."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from vinecli.autopilot.base import RunStatus
from vinecli.autopilot.registry import make_autopilot
from vinecli.specs.mission import MissionSpec


@pytest.fixture(scope="module")
def flat(tmp_path_factory: pytest.TempPathFactory, repo: Path) -> Any:
    from vinecli.world import build_world, load_world

    return load_world(build_world(repo / "worlds" / "flat.yaml", tmp_path_factory.mktemp("w") / "flat"))


def fly(world: Any, phases: list[dict[str, Any]], *, truth: bool = False, max_s: float = 40.0, **kw: Any) -> Any:
    from vinecli.sim.runner import run_simulation

    m = MissionSpec(name="t", truth=truth, max_duration_s=max_s, phases=phases, **kw)
    ap = make_autopilot("builtin")
    try:
        return run_simulation(world, m, ap, seed=7)
    finally:
        ap.close()


def test_takeoff_hold_land(flat: Any) -> None:
    res = fly(flat, [{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "hold", "duration_s": 8.0}, {"type": "land"}])
    assert res.status is RunStatus.COMPLETED, res.detail
    ts = res.timeseries
    t, z = ts["t_s"], ts["pos_enu_z_m"]
    home_z = float(z[0])
    kinds = [e.kind for e in res.events]
    for k in ("liftoff", "touchdown", "land_detected", "mode", "phase"):
        assert k in kinds
    t_hold = [e.t_us * 1e-6 for e in res.events if e.kind == "phase" and e.data.get("index") == 1]
    # from 4 s into the hold: the full tank's mass is learnt in the air (valid ~2 s above 1 m), then the
    # vertical integrator settles (see tests/autopilot/test_closed_loop.py)
    hold = (t > t_hold[0] + 4.0) & (t < t_hold[1])
    assert float(np.mean(z[hold])) == pytest.approx(home_z + 3.0, abs=0.15)
    assert float(np.max(np.abs(z[hold] - (home_z + 3.0)))) < 0.3
    assert float(np.max(np.hypot(ts["pos_enu_x_m"][hold], ts["pos_enu_y_m"][hold]))) < 1.0
    # the recorded setpoint is the autopilot's
    assert np.all(np.isfinite(ts["sp_pos_enu_z_m"][hold]))
    assert float(np.mean(ts["sp_pos_enu_z_m"][hold])) == pytest.approx(home_z + 3.0, abs=0.01)
    # the autopilot's land detector followed the runner's (truth) touchdown by PX4's ~1 s and disarmed
    t_td = next(e.t_us for e in res.events if e.kind == "touchdown") * 1e-6
    t_ld = next(e.t_us for e in res.events if e.kind == "land_detected") * 1e-6
    assert 0.9 <= t_ld - t_td < 1.6
    assert ts["armed"][-1] == 0.0
    assert float(np.max(ts["tilt_rad"])) < math.radians(10.0)
    assert res.metrics["max_impact_speed_mps"] < 1.2


def test_spray_pass_over_rows(flat: Any) -> None:
    rows = [[[2.0, -6.0], [2.0, 6.0]], [[5.0, 6.0], [5.0, -6.0]]]
    res = fly(flat, [{"type": "takeoff", "altitude_agl_m": 2.0},
                     {"type": "spray", "rows": rows, "height_agl_m": 2.0, "speed_mps": 2.0, "flow_lps": 0.02},
                     {"type": "hold", "duration_s": 1.0}], max_s=60.0)
    assert res.status is RunStatus.COMPLETED, res.detail
    ts = res.timeseries
    flow = ts["tank_flow_cmd_lps"]
    on = flow > 0.0
    assert on.sum() > 100
    x, y, agl = ts["pos_enu_x_m"][on], ts["pos_enu_y_m"][on], ts["height_agl_m"][on]
    dist = np.minimum(np.abs(x - 2.0), np.abs(x - 5.0))
    assert float(np.max(dist)) < 0.5  # flow only over the rows (3 m apart, wider than the effective swath: a pass each)
    # ... run on past the row ends by the spray footprint (the end vines get their dose) and the pump's ramp, the
    # section opening the pump's lag (speed x tau_up) ahead of a pass start
    from vinecli.rows.spray_rate import spray_pattern

    v, pat = flat.vehicle, spray_pattern(flat.vehicle, 2.0, 2.0)
    run_on = pat.footprint_radius_m + pat.along_offset_m + 2 * 2.0 * v.sprayer.pump.tau_up_s + 0.2
    assert 6.0 + 0.5 < float(np.max(np.abs(y))) < 6.0 + run_on
    assert float(np.mean(agl)) == pytest.approx(2.0, abs=0.25)
    # both rows covered end to end
    for xr in (2.0, 5.0):
        yr = y[np.abs(x - xr) < 0.5]
        assert yr.min() < -5.0 and yr.max() > 5.0
    # the tank drains at the commanded rate while spraying
    t = ts["t_s"]
    dt = float(np.median(np.diff(t)))
    drained = float(ts["tank_level_l"][0] - ts["tank_level_l"][-1])
    assert drained == pytest.approx(float(flow[on].sum()) * dt, rel=0.05)  # the flow scaled with the ground speed
    edges = int(np.sum(on[1:] != on[:-1]))
    assert edges == 4  # on/off per row


def test_geofence_breach_returns_home(flat: Any) -> None:
    """A 1-cos gust (18 m/s peak, towards east) shoves the hovering vehicle through the fence 2 m east of home."""
    fence = {"polygon_enu": [[-6.0, -6.0], [2.0, -6.0], [2.0, 6.0], [-6.0, 6.0]], "max_altitude_agl_m": 20.0,
             "action": "rtl"}
    gust = {"law": {"type": "gust", "peak_mps": 18.0, "start_s": 6.0, "duration_s": 4.0, "heading_deg": 90.0}}
    res = fly(flat, [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "hold", "duration_s": 12.0}],
              geofence=fence, wind=gust, max_s=60.0)
    assert res.status is RunStatus.FAILSAFE, res.detail  # home and down, but the mission was not flown to its end
    assert "geofence" in res.detail and "returned to launch" in res.detail
    gf = [e for e in res.events if e.kind == "geofence"]
    assert len(gf) == 1
    assert gf[0].data["action"] == "rtl" and gf[0].data["gf_action"] == 3 and gf[0].data["violation"] == "polygon"
    assert 1.5 < gf[0].data["x"] < 3.5
    fs = [e for e in res.events if e.kind == "failsafe"]
    assert len(fs) == 1 and fs[0].data["action"] == "rtl" and fs[0].data["position_enu"][0] > 1.5  # truth added
    ts = res.timeseries
    assert float(np.max(ts["pos_enu_x_m"])) < 5.0
    assert math.hypot(ts["pos_enu_x_m"][-1], ts["pos_enu_y_m"][-1]) < 0.7  # back home (GNSS-grade accuracy)
    assert ts["on_ground"][-1] == 1.0 and ts["armed"][-1] == 0.0


def test_a_goto_outside_the_fence_is_refused_before_arming(flat: Any) -> None:
    """PX4's mission feasibility check: a planned point outside the fence -> preflight_failed, never armed."""
    fence = {"polygon_enu": [[-6.0, -6.0], [6.0, -6.0], [6.0, 6.0], [-6.0, 6.0]], "action": "rtl"}
    res = fly(flat, [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "goto", "position_enu": [15.0, 0.0]}],
              geofence=fence)
    assert res.status is RunStatus.PREFLIGHT_FAILED
    assert "'geofence_plan'" in res.detail and "phase 1 (goto) at (15.00, 0.00)" in res.detail
    assert res.timeseries["armed"].max() == 0.0 and res.timeseries["on_ground"].all()
    assert res.sim_time_s < 2.5  # ends when it would have armed
