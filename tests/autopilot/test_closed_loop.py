"""Closed loop against the pure-Python rigid-body double (real motor model and sensors):
takeoff accuracy, integral action for mass changes, goto, landing, the two failure
detections and the steady tilt into a horizontal force."""

from __future__ import annotations

import math
import statistics

import pytest
from repo_paths import VEHICLES

from vinecli.autopilot.base import RunStatus
from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.specs import load_spec
from vinecli.specs.mission import MissionSpec
from vinecli.specs.vehicle import VehicleSpec

from .rigid_body import G, RigidBodyDouble, Trace

VEHICLE_NAMES = ["x500", "x500-sprayer", "hex-sprayer"]


def vehicle(name: str) -> VehicleSpec:
    return load_spec(VEHICLES / f"{name}.yaml", VehicleSpec)


def mission(*phases: dict, truth: bool = False) -> MissionSpec:
    return MissionSpec(name="t", truth=truth, phases=list(phases))


def fly(v: VehicleSpec, m: MissionSpec, seconds: float, **kw: object) -> tuple[RigidBodyDouble, BuiltinAutopilot, Trace]:
    on_step = kw.pop("on_step", None)
    setup = kw.pop("setup", None)
    d = RigidBodyDouble(v, **kw)  # type: ignore[arg-type]
    if setup is not None:
        setup(d)
    ap = BuiltinAutopilot()
    ap.reset(d.context(m))
    tr = d.fly(ap, seconds, on_step=on_step)  # type: ignore[arg-type]
    return d, ap, tr


def window(tr: Trace, t0: float, t1: float) -> list[int]:
    return [i for i, t in enumerate(tr.t) if t0 <= t <= t1]


@pytest.mark.parametrize("name", VEHICLE_NAMES)
def test_takeoff_settles_within_10_cm_truth(name: str) -> None:
    v = vehicle(name)
    _, ap, tr = fly(v, mission({"type": "takeoff", "altitude_agl_m": 5.0}, {"type": "hold", "duration_s": 11.0}, truth=True), 22)
    target = v.frame.landing_gear_height_m + 5.0
    assert ap.status().status is RunStatus.COMPLETED
    t_reach = next(t for t, p in zip(tr.t, tr.pos, strict=True) if p[2] > target - 0.3)
    # the liquid's mass is learnt in flight (the hover thrust estimate is valid ~2 s after 1 m): the
    # velocity integrator then settles with the slow pole of PX4's gains (~2.3 s); 6 s after reaching
    idx = window(tr, t_reach + 6.0, tr.t[-1])
    assert len(idx) > 50
    assert max(abs(tr.pos[i][2] - target) for i in idx) < 0.1
    assert max(tr.pos[i][2] for i in range(len(tr.t))) < target + 0.4  # modest overshoot


@pytest.mark.parametrize("name", VEHICLE_NAMES)
def test_takeoff_with_the_estimator(name: str) -> None:
    v = vehicle(name)
    _, ap, tr = fly(v, mission({"type": "takeoff", "altitude_agl_m": 5.0}, {"type": "hold", "duration_s": 13.0}), 28)
    target = v.frame.landing_gear_height_m + 5.0
    assert ap.status().status is RunStatus.COMPLETED
    idx = window(tr, tr.t[-1] - 6.0, tr.t[-1])  # settled (the liquid's mass learnt in flight: see above)
    zs = [tr.pos[i][2] for i in idx]
    assert statistics.mean(zs) == pytest.approx(target, abs=0.05)
    assert max(abs(z - target) for z in zs) < 0.1  # with baro/GNSS noise
    assert max(math.hypot(tr.pos[i][0], tr.pos[i][1]) for i in idx) < 0.6  # GNSS sigma 0.3 m


def test_no_steady_altitude_error_after_a_mass_step() -> None:
    v = vehicle("x500")
    step_t = 10.0

    def add_payload(d: RigidBodyDouble) -> None:
        if d.t_us == int(step_t * 1e6):
            d.mass += 0.5  # +25 %, unknown to the autopilot

    d, ap, tr = fly(v, mission({"type": "takeoff", "altitude_agl_m": 5.0}, {"type": "hold", "duration_s": 30.0}, truth=True),
                    34, on_step=add_payload)
    target = v.frame.landing_gear_height_m + 5.0
    dip = min(tr.pos[i][2] for i in window(tr, step_t, step_t + 5))
    assert dip < target - 0.05  # the step is felt ...
    late = window(tr, step_t + 18.0, tr.t[-1])
    assert max(abs(tr.pos[i][2] - target) for i in late) < 0.02  # ... and the integral removes it
    w_before = statistics.mean(sum(tr.w_cmd[i]) / 4 for i in window(tr, step_t - 3, step_t - 0.1))
    w_after = statistics.mean(sum(tr.w_cmd[i]) / 4 for i in late)
    assert w_after / w_before == pytest.approx(math.sqrt(2.5 / 2.0), rel=0.01)  # hover w ∝ sqrt(m)


def test_draining_tank_keeps_altitude_and_motor_speed_falls() -> None:
    v = vehicle("x500-sprayer")
    m = mission({"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "sprayer", "flow_lps": 0.05},
                {"type": "hold", "duration_s": 25.0})
    d, ap, tr = fly(v, m, 40)
    assert d.liquid_l == pytest.approx(0.0, abs=1e-9)  # 1 L at 0.05 L/s empties in 20 s
    target = v.frame.landing_gear_height_m + 3.0
    idx = [i for i in window(tr, 6.0, tr.t[-1]) if tr.mode[i] == "AUTO.LOITER"]
    zs = [tr.pos[i][2] for i in idx]
    assert statistics.mean(zs) == pytest.approx(target, abs=0.1)
    w_full = statistics.mean(statistics.mean(tr.w_cmd[i]) for i in idx[:50])
    w_empty = statistics.mean(statistics.mean(tr.w_cmd[i]) for i in idx[-100:])
    m_full, m_empty = v.dry_mass() + 1.0, v.dry_mass()
    assert w_empty < w_full
    assert w_empty / w_full == pytest.approx(math.sqrt(m_empty / m_full), rel=0.03)


@pytest.mark.parametrize("name", ["x500", "hex-sprayer"])
def test_goto_reaches_the_target(name: str) -> None:
    v = vehicle(name)
    m = mission({"type": "takeoff", "altitude_agl_m": 4.0},
                {"type": "goto", "position_enu": [12.0, -6.0], "altitude_agl_m": 6.0, "speed_mps": 3.0},
                {"type": "hold", "duration_s": 4.0}, truth=True)
    _, ap, tr = fly(v, m, 40)
    assert ap.status().status is RunStatus.COMPLETED
    end = window(tr, tr.t[-1] - 2.0, tr.t[-1])
    for i in end:
        assert math.dist(tr.pos[i][:2], (12.0, -6.0)) < 0.2
        assert tr.pos[i][2] == pytest.approx(v.frame.landing_gear_height_m + 6.0, abs=0.15)
    overshoot = max(tr.pos[i][0] for i in range(len(tr.t))) - 12.0
    assert overshoot < 0.6
    speeds = [math.hypot(tr.vel[i][0], tr.vel[i][1]) for i in range(len(tr.t))]
    assert max(speeds) == pytest.approx(3.0, abs=0.4)


def test_land_detects_touchdown_and_disarms() -> None:
    v = vehicle("x500")
    m = mission({"type": "takeoff", "altitude_agl_m": 3.0}, {"type": "land", "descent_speed_mps": 0.8})
    d, ap, tr = fly(v, m, 30)
    st = ap.status()
    assert st.status is RunStatus.COMPLETED
    assert st.mode == "DISARMED"
    assert d.on_ground
    ev = ap.drain_events()
    kinds = [e.kind for e in ev]
    assert "land_detected" in kinds
    t_land = next(e.t_us for e in ev if e.kind == "land_detected") * 1e-6
    t_ground = next(t for t, g, i in zip(tr.t, tr.on_ground, range(len(tr.t)), strict=True) if g and i > 100)
    assert 0.0 < t_land - t_ground < 2.0  # detected shortly after the real touchdown
    assert next(e for e in ev if e.kind == "arming" and e.data["armed"] is False).t_us == int(t_land * 1e6)
    # the descent followed the commanded speed
    idx = [i for i in range(len(tr.t)) if tr.mode[i] == "AUTO.LAND" and 1.0 < tr.pos[i][2] < 2.5]
    assert statistics.mean(tr.vel[i][2] for i in idx) == pytest.approx(-0.8, abs=0.1)


@pytest.mark.parametrize("name, payload", [("x500", 1.6), ("hex-sprayer", 4.5)])
def test_overloaded_vehicle_cannot_take_off(name: str, payload: float) -> None:
    v0 = vehicle(name)
    v = v0.model_copy(update={"payload": v0.payload.model_copy(update={"mass_kg": payload})})
    m = mission({"type": "takeoff", "altitude_agl_m": 5.0}, {"type": "hold", "duration_s": 5.0})
    d = RigidBodyDouble(v)
    assert d.mass * G > v.max_thrust()  # thrust-to-weight below 1
    ap = BuiltinAutopilot()
    ap.reset(d.context(m))
    tr = d.fly(ap, 15)
    st = ap.status()
    assert st.status is RunStatus.CANNOT_TAKE_OFF
    assert "thrust-limited" in st.detail
    assert max(p[2] for p in tr.pos) < v.frame.landing_gear_height_m + 0.05
    t_arm = next(t for t, mo in zip(tr.t, tr.mode, strict=True) if mo == "AUTO.TAKEOFF")
    assert 2.0 <= tr.t[-1] - t_arm <= 4.0
    assert [e.kind for e in ap.drain_events()][-1] == "status"


def test_a_huge_disturbance_ends_in_lost_control() -> None:
    v = vehicle("x500")

    def setup(d: RigidBodyDouble) -> None:
        d.ext_torque = lambda t: (2.0, 0.5, 0.0) if 8.0 < t < 8.4 else (0.0, 0.0, 0.0)

    d, ap, tr = fly(v, mission({"type": "takeoff", "altitude_agl_m": 5.0}, {"type": "hold", "duration_s": 20.0}), 20,
                    setup=setup)
    st = ap.status()
    assert st.status is RunStatus.LOST_CONTROL
    assert 8.0 < tr.t[-1] < 8.6
    assert math.degrees(d.tilt()) >= v.control.lost_control_tilt_deg - 5.0
    assert st.mode == "DISARMED"


def test_a_small_disturbance_is_rejected() -> None:
    v = vehicle("x500")

    def setup(d: RigidBodyDouble) -> None:
        d.ext_torque = lambda t: (0.3, 0.0, 0.0) if 8.0 < t < 8.05 else (0.0, 0.0, 0.0)

    d, ap, tr = fly(v, mission({"type": "takeoff", "altitude_agl_m": 5.0}, {"type": "hold", "duration_s": 8.0}, truth=True), 20,
                    setup=setup)
    assert ap.status().status is RunStatus.COMPLETED
    peak = max(abs(tr.rpy[i][0]) for i in window(tr, 8.0, 9.0))
    assert math.radians(0.5) < peak < math.radians(5.0)
    assert max(abs(tr.rpy[i][0]) for i in window(tr, 10.5, 12.0)) < math.radians(0.3)


@pytest.mark.parametrize("name, force", [("x500", 5.0), ("x500-sprayer", -6.0), ("hex-sprayer", 8.0)])
def test_hover_under_a_horizontal_force_tilts_into_it(name: str, force: float) -> None:
    v = vehicle(name)

    def setup(d: RigidBodyDouble) -> None:
        d.ext_force = lambda t: (force, 0.0, 0.0) if t > 8.0 else (0.0, 0.0, 0.0)

    d, ap, tr = fly(v, mission({"type": "takeoff", "altitude_agl_m": 5.0}, {"type": "hold", "duration_s": 22.0}, truth=True), 30,
                    setup=setup)
    expected = math.atan(abs(force) / (d.mass * G))
    late = window(tr, 24.0, tr.t[-1])
    pitch = statistics.mean(tr.rpy[i][1] for i in late)
    # force towards +x (east, nose direction): thrust leans towards -x -> negative pitch in FLU
    assert math.copysign(1.0, pitch) == -math.copysign(1.0, force)
    assert abs(pitch) == pytest.approx(expected, abs=math.radians(0.3))
    assert max(abs(tr.pos[i][0]) for i in late) < 0.1  # the integral brings it back over the setpoint
