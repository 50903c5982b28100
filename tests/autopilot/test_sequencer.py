"""Mission sequencer: phase/mode transitions and events, setpoints, sprayer, open loop,
spray passes over rows, geofence actions, timeouts, registry."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from repo_paths import VEHICLES

from vinecli.autopilot.base import RunStatus
from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.autopilot.registry import available_autopilots, make_autopilot
from vinecli.errors import InputError
from vinecli.specs import load_spec
from vinecli.specs.mission import GeofenceSpec, MissionSpec
from vinecli.specs.vehicle import VehicleSpec

from .rigid_body import RigidBodyDouble, Trace


def vehicle(name: str = "x500") -> VehicleSpec:
    return load_spec(VEHICLES / f"{name}.yaml", VehicleSpec)


def push(t: float) -> tuple[float, float, float]:
    """A 20 N eastward shove for 1 s at t = 8 s (out of the test fence), N ENU."""
    return (20.0, 0.0, 0.0) if 8.0 <= t < 9.0 else (0.0, 0.0, 0.0)


def run(phases: list[dict], seconds: float, *, name: str = "x500", truth: bool = True,
        force: Callable[[float], tuple[float, float, float]] | None = None, **ctx: object
        ) -> tuple[RigidBodyDouble, BuiltinAutopilot, Trace, list]:
    """Fly ``phases`` on the rigid-body double; ``force``: extra world force (N, ENU) of time (s)."""
    d = RigidBodyDouble(vehicle(name))
    d.ext_force = force
    ap = BuiltinAutopilot()
    ap.reset(d.context(MissionSpec(name="t", truth=truth, phases=phases), **ctx))
    tr = d.fly(ap, seconds)
    return d, ap, tr, ap.drain_events()


def test_phase_and_mode_transitions() -> None:
    phases = [{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "hold", "duration_s": 2.0},
              {"type": "goto", "position_enu": [4.0, 0.0]}, {"type": "land"}]
    d, ap, tr, ev = run(phases, 60)
    st = ap.status()
    assert st.status is RunStatus.COMPLETED and st.detail == "all phases completed"
    assert [e.data["mode"] for e in ev if e.kind == "mode"] == ["AUTO.TAKEOFF", "AUTO.LOITER", "AUTO.MISSION", "AUTO.LAND",
                                                                "DISARMED"]
    ph = [(e.data["index"], e.data["event"]) for e in ev if e.kind == "phase"]
    assert ph == [(0, "start"), (0, "end"), (1, "start"), (1, "end"), (2, "start"), (2, "end"), (3, "start"), (3, "end")]
    assert [e.data["armed"] for e in ev if e.kind == "arming"] == [True, False]
    assert ev[-1].kind == "status" and ev[-1].data["status"] == "completed"
    times = [e.t_us for e in ev]
    assert times == sorted(times)
    # hold lasted its duration
    t_hold = [e.t_us for e in ev if e.kind == "phase" and e.data["index"] == 1]
    assert (t_hold[1] - t_hold[0]) * 1e-6 == pytest.approx(2.0, abs=0.03)
    # setpoints are recorded while flying and NaN while disarmed
    assert math.isnan(tr.sp[-1][0])
    flying = [i for i, m in enumerate(tr.mode) if m == "AUTO.MISSION"]
    assert all(math.isfinite(tr.sp[i][0]) for i in flying)
    assert tr.sp[flying[-1]][0] == pytest.approx(4.0, abs=0.6)
    assert st.phase_index == 3


def test_estimator_waits_before_arming() -> None:
    d, ap, tr, ev = run([{"type": "takeoff", "altitude_agl_m": 2.0}], 10, truth=False)
    t_arm = next(e.t_us for e in ev if e.kind == "arming") * 1e-6
    assert 1.4 < t_arm < 2.0  # the estimator settles 1.5 s after its first GNSS + baro fix
    assert tr.mode[0] == "DISARMED"
    assert all(w == 0.0 for w in tr.w_cmd[0])


def test_sprayer_and_waypoints_flow() -> None:
    phases = [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "sprayer", "flow_lps": 0.02},
              {"type": "waypoints", "waypoints": [[3.0, 0.0, 2.0], [3.0, 3.0, 2.5]], "speed_mps": 2.0, "flow_lps": 0.04},
              {"type": "sprayer", "flow_lps": 0.0}, {"type": "hold", "duration_s": 1.0}]
    d, ap, tr, ev = run(phases, 40, name="x500-sprayer")
    assert ap.status().status is RunStatus.COMPLETED
    flows = [e.data["flow_lps"] for e in ev if e.kind == "sprayer"]
    assert flows == [0.02, 0.0]  # a sprayer event when it switches on and off
    assert tr.flow[-1] == 0.0
    assert max(tr.flow) == 0.04
    assert d.liquid_l < 1.0
    # the sprayer phase does not change the mode
    modes = [e.data["mode"] for e in ev if e.kind == "mode"]
    assert modes == ["AUTO.TAKEOFF", "AUTO.MISSION", "AUTO.LOITER"]


def test_open_loop_schedule_then_controller_takes_over() -> None:
    v = vehicle()
    w_hover = v.hover_speed(v.dry_mass())
    phases = [{"type": "open_loop", "duration_s": 1.0, "schedule": [[0.0, 300.0], [0.4, [310.0, 320.0, 330.0, 340.0]]]},
              {"type": "open_loop", "duration_s": 0.5, "rotor_speeds_rad_s": 200.0},
              {"type": "takeoff", "altitude_agl_m": 2.0}]
    d, ap, tr, ev = run(phases, 20)
    assert ap.status().status is RunStatus.COMPLETED
    assert tr.mode[0] == "OPEN_LOOP"
    at = {round(t, 2): w for t, w in zip(tr.t, tr.w_cmd, strict=True)}
    assert at[0.2] == (300.0,) * 4
    assert at[0.6] == (310.0, 320.0, 330.0, 340.0)
    assert at[1.2] == (200.0,) * 4
    assert [e.data["mode"] for e in ev if e.kind == "mode"][:2] == ["OPEN_LOOP", "AUTO.TAKEOFF"]
    assert max(p[2] for p in tr.pos) > 2.0
    assert w_hover > 300.0


def test_open_loop_rejects_a_wrong_rotor_count() -> None:
    ap = BuiltinAutopilot()
    d = RigidBodyDouble(vehicle())
    with pytest.raises(InputError, match="4 rotors"):
        ap.reset(d.context(MissionSpec(name="t", phases=[{"type": "open_loop", "duration_s": 1.0,
                                                          "rotor_speeds_rad_s": [1.0, 2.0]}])))


ROWS = (((2.0, 0.0), (2.0, 12.0)), ((4.0, 12.0), (4.0, 0.0)), ((6.0, 0.0), (6.0, 12.0)))


def _dist_to(x: float, y: float, line: list[tuple[float, float]]) -> float:
    best = math.inf
    for (x0, y0), (x1, y1) in zip(line[:-1], line[1:], strict=True):
        t = max(0.0, min(1.0, ((x - x0) * (x1 - x0) + (y - y0) * (y1 - y0)) / ((x1 - x0) ** 2 + (y1 - y0) ** 2)))
        best = min(best, math.hypot(x - x0 - t * (x1 - x0), y - y0 - t * (y1 - y0)))
    return best


def test_spray_passes_follow_the_plan_with_the_flow_scaled_by_speed_over_the_passes_only() -> None:
    from vinecli.rows.spray_rate import phase_plan
    from vinecli.specs.mission import SprayPhase

    spec = {"type": "spray", "height_agl_m": 2.5, "speed_mps": 2.0, "flow_lps": 0.01}
    phases = [{"type": "takeoff", "altitude_agl_m": 2.0}, spec, {"type": "land"}]
    d, ap, tr, ev = run(phases, 120, name="x500-sprayer", vine_rows_enu=ROWS)
    assert ap.status().status is RunStatus.COMPLETED
    plan = phase_plan(SprayPhase.model_validate(spec), vehicle("x500-sprayer"), [list(r) for r in ROWS], (0.0, 0.0))
    passes = [leg.points for leg in plan.legs if leg.spray]
    spraying = [i for i, f in enumerate(tr.flow) if f > 0.0]
    assert len(spraying) > 200
    for i in spraying:  # flow only over the planned passes (they run on past the row ends by the footprint)
        x, y, z = tr.pos[i]
        assert min(_dist_to(x, y, p) for p in passes) < 0.7  # sections open only within 0.7 m of the path
        assert z == pytest.approx(2.5, abs=0.3)  # above the flat terrain at z = 0
    # the flow follows the ground speed: litres per metre = flow / speed of the phase
    per_m = [tr.flow[i] / math.hypot(*tr.vel[i][:2]) for i in spraying if math.hypot(*tr.vel[i][:2]) > 1.0]
    assert sorted(per_m)[len(per_m) // 2] == pytest.approx(0.01 / 2.0, rel=0.05)
    ys = [tr.pos[i][1] for i in spraying]
    assert min(ys) < 0.0 and max(ys) > 12.0  # the rows covered end to end, and past them
    # sections closed in the turns: one opening and one closing per pass
    edges = sum(1 for a, b in zip(tr.flow, tr.flow[1:], strict=False) if (a > 0) != (b > 0))
    assert edges == 2 * len(passes)


def test_spray_until_empty_repeats_passes() -> None:
    phases = [{"type": "takeoff", "altitude_agl_m": 2.0},
              {"type": "spray", "height_agl_m": 2.0, "speed_mps": 2.5, "flow_lps": 0.1, "until": "empty"}]
    d, ap, tr, ev = run(phases, 60, name="x500-sprayer", vine_rows_enu=ROWS[:1])
    assert ap.status().status is RunStatus.COMPLETED
    assert d.liquid_l == pytest.approx(0.0, abs=1e-9)
    # a single 12 m row at 2.5 m/s takes ~5 s and holds 0.5 L: several passes both ways were flown
    on = [i for i, f in enumerate(tr.flow) if f > 0.0]
    ys = [tr.pos[i][1] for i in on]
    assert sum(1 for a, b in zip(ys, ys[1:], strict=False) if abs(b - a) > 0.0 and (b - a) * (ys[1] - ys[0]) < 0) > 0


def test_spray_without_rows_is_an_input_error() -> None:
    ap = BuiltinAutopilot()
    d = RigidBodyDouble(vehicle("x500-sprayer"))
    with pytest.raises(InputError, match="no vine rows"):
        ap.reset(d.context(MissionSpec(name="t", phases=[{"type": "spray", "flow_lps": 0.01}])))
    with pytest.raises(InputError, match="out of range"):
        ap.reset(d.context(MissionSpec(name="t", phases=[{"type": "spray", "flow_lps": 0.01, "rows": [5]}]),
                           vine_rows_enu=ROWS))


def _fence(action: str) -> GeofenceSpec:
    return GeofenceSpec(polygon_enu=[(-5.0, -5.0), (8.0, -5.0), (8.0, 5.0), (-5.0, 5.0)], action=action)


# the plan stays inside the fence (preflight refuses anything else); a shove pushes the vehicle out
FENCE_PHASES = [{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "goto", "position_enu": [6.0, 0.0], "speed_mps": 3.0},
                {"type": "hold", "duration_s": 8.0}]


@pytest.mark.parametrize("action", ["none", "warn"])
def test_geofence_report_only_actions(action: str) -> None:
    d, ap, tr, ev = run(FENCE_PHASES, 40, geofence=_fence(action), force=push)
    gf = [e for e in ev if e.kind == "geofence"]
    assert len(gf) == 1 and gf[0].data["action"] == action and gf[0].data["violation"] == "polygon"
    assert gf[0].data["x"] == pytest.approx(8.0, abs=0.5)
    assert ap.status().status is RunStatus.COMPLETED
    assert d.pos[0] == pytest.approx(6.0, abs=0.6)  # the mission went on
    fs = [e for e in ev if e.kind == "failsafe"]
    assert [e.data["action"] for e in fs] == ([] if action == "none" else ["warn"])


def test_geofence_hold_stops_near_the_fence() -> None:
    d, ap, tr, ev = run(FENCE_PHASES, 25, geofence=_fence("hold"), force=push)
    gf = next(e for e in ev if e.kind == "geofence")
    assert gf.data["gf_action"] == 2
    st = ap.status()
    assert st.status is RunStatus.RUNNING and st.mode == "AUTO.LOITER"  # holds until the run's time limit
    assert 8.0 < d.pos[0] < 10.5 and abs(d.vel[0]) < 0.1


def test_geofence_rtl_returns_home_and_lands() -> None:
    d, ap, tr, ev = run(FENCE_PHASES, 60, geofence=_fence("rtl"), force=push)
    st = ap.status()
    assert st.status is RunStatus.FAILSAFE and "returned to launch" in st.detail  # the mission was not finished
    assert "AUTO.RTL" in [e.data["mode"] for e in ev if e.kind == "mode"]
    assert math.hypot(d.pos[0], d.pos[1]) < 0.3 and d.on_ground
    assert max(p[2] for p in tr.pos) >= 5.0  # climbed to the 5 m return altitude


def test_geofence_land_lands_in_place() -> None:
    d, ap, tr, ev = run(FENCE_PHASES, 40, geofence=_fence("land"), force=push)
    st = ap.status()
    assert st.status is RunStatus.FAILSAFE and "landed" in st.detail
    gf = next(e for e in ev if e.kind == "geofence")
    assert d.on_ground and abs(d.pos[0] - gf.data["x"]) < 1.5


def test_geofence_terminate_and_max_altitude() -> None:
    fence = GeofenceSpec(max_altitude_agl_m=4.0, action="terminate")
    d, ap, tr, ev = run([{"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "hold", "duration_s": 10.0}], 20,
                        geofence=fence, force=lambda t: (0.0, 0.0, 40.0) if t >= 6.0 else (0.0, 0.0, 0.0))  # updraft
    st = ap.status()
    assert st.status is RunStatus.GEOFENCE_TERMINATED
    gf = next(e for e in ev if e.kind == "geofence")
    assert gf.data["violation"] == "max_altitude" and gf.data["gf_action"] == 4
    assert tr.w_cmd[-1] == (0.0,) * 4 or all(w == 0.0 for w in ap.step(d.observe()).rotor_speed_cmd)


def test_phase_timeout_ends_the_run() -> None:
    d, ap, tr, ev = run([{"type": "takeoff", "altitude_agl_m": 3.0},
                         {"type": "goto", "position_enu": [100.0, 0.0], "speed_mps": 1.0, "timeout_s": 3.0}], 30)
    st = ap.status()
    assert st.status is RunStatus.TIMEOUT and "phase 1 (goto)" in st.detail


def test_registry() -> None:
    assert {"builtin", "px4"} <= set(available_autopilots())
    ap = make_autopilot("builtin")
    assert isinstance(ap, BuiltinAutopilot) and ap.name == "builtin"
    with pytest.raises(InputError, match="unknown option"):  # ground truth comes with the context, not as an option
        make_autopilot("builtin", truth=True)
    with pytest.raises(InputError, match="unknown autopilot 'nope'"):
        make_autopilot("nope")
    with pytest.raises(InputError, match="unknown option"):
        make_autopilot("builtin", colour="red")


def test_replace_phases_at_run_time() -> None:
    d = RigidBodyDouble(vehicle())
    ap = BuiltinAutopilot()
    ap.reset(d.context(MissionSpec(name="t", truth=True, phases=[{"type": "takeoff", "altitude_agl_m": 2.0},
                                                                 {"type": "hold", "duration_s": 60.0}])))
    d.fly(ap, 6.0)
    assert ap.status().mode == "AUTO.LOITER" and ap.status().phase_index == 1
    from vinecli.specs.mission import GotoPhase, LandPhase

    ap.replace_phases([GotoPhase(position_enu=(3.0, 0.0)), LandPhase()])
    assert ap.status().phase_index == 0
    d.fly(ap, 30.0)
    st = ap.status()
    assert st.status is RunStatus.COMPLETED and st.mode == "DISARMED"
    assert d.pos[0] == pytest.approx(3.0, abs=0.3) and d.on_ground
