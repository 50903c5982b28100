"""The hover thrust estimator (PX4 mc_hover_thrust_estimator): the filter against its measurement
model, the in-air / valid / reset logic, and in closed loop on the rigid-body double: under a known
mass it converges to the ratio m g / T_max, the rotors then turn at the hover law's sqrt(m g / (n k_f)),
and it follows the mass as the tank drains."""

from __future__ import annotations

import random
import statistics

import pytest

from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.autopilot.hover_thrust import HoverThrustEkf, HoverThrustEstimator
from vinecli.specs.mission import MissionSpec

from .rigid_body import G, RigidBodyDouble
from .test_closed_loop import fly, vehicle

DT_US = 20_000


def test_filter_converges_to_the_hover_thrust_of_its_model() -> None:
    """Measurements a = g T / Th - g (+ noise) at varying thrust: the estimate goes to Th."""
    rng = random.Random(1)
    ekf = HoverThrustEkf(0.40)
    true_th = 0.55
    for k in range(1500):
        thrust = true_th * (1.0 + 0.2 * ((k % 50) / 50.0 - 0.5))
        ekf.predict(0.02)
        ekf.fuse_acc_z(G * thrust / true_th - G + rng.gauss(0.0, 0.5), thrust)
    assert ekf.hover_thr == pytest.approx(true_th, abs=0.005)
    assert ekf.state_var < 1e-3
    assert ekf.acc_var == 1.0  # learnt down from 5 to PX4's floor (the noise variance is 0.25)


def test_filter_clamps_to_its_range_and_recovers_from_a_jump() -> None:
    ekf = HoverThrustEkf(0.40, hover_thr_min=0.30, hover_thr_max=0.50)
    for _ in range(500):
        ekf.predict(0.02)
        ekf.fuse_acc_z(G * 0.6 / 0.6 - G, 0.6)  # hovering at 0.6: outside the range
    assert ekf.hover_thr == pytest.approx(0.50)
    # a sudden change inside the range (payload dropped): the rejected measurements bump the variance
    ekf = HoverThrustEkf(0.45, hover_thr_min=0.25, hover_thr_max=0.65)
    for _ in range(1000):
        ekf.predict(0.02)
        ekf.fuse_acc_z(0.0, 0.45)
    assert ekf.hover_thr == pytest.approx(0.45, abs=1e-3) and ekf.state_var < 1e-4
    for _ in range(1000):
        ekf.predict(0.02)
        ekf.fuse_acc_z(G * 0.45 / 0.30 - G, 0.45)  # the same thrust now accelerates at 4.9 m/s²
    assert ekf.hover_thr == pytest.approx(0.30, abs=0.01)


def test_runs_only_in_the_air_valid_after_two_seconds_reset_when_disarmed() -> None:
    est = HoverThrustEstimator(0.40)
    t = 0
    for _ in range(100):  # armed, on the ground (landed, 0.1 m): nothing learnt
        t += DT_US
        est.update(t, True, True, 0.1, 0.0, 0.0, G * 0.5 / 0.55 - G, 0.5)
    assert not est.in_air and est.hover_thrust == 0.40 and not est.valid
    t_valid = None
    for _ in range(400):  # not landed, 2 m above the ground: in the air
        t += DT_US
        est.update(t, True, False, 2.0, 0.0, 0.0, G * 0.5 / 0.55 - G, 0.5)
        if est.valid and t_valid is None:
            t_valid = t
    assert est.in_air and est.hover_thrust == pytest.approx(0.55, abs=0.005)
    assert t_valid is not None
    # valid once the variance stayed below 1e-3 with the innovation inside the gate for 2 s
    est2 = HoverThrustEstimator(0.40)
    t2, t_ok = 0, None
    while not est2.valid:
        t2 += DT_US
        est2.update(t2, True, False, 2.0, 0.0, 0.0, G * 0.5 / 0.55 - G, 0.5)
        ok = est2.hover_thrust_var < 1e-3 and est2.ekf.innov_test_ratio < 1.0
        t_ok = (t_ok if t_ok is not None else t2) if ok else None
    assert t_ok is not None and t2 - t_ok == 2_000_000
    # landed: not valid any more; disarmed: back to MPC_THR_HOVER
    est.update(t + DT_US, True, True, 0.1, 0.0, 0.0, 0.0, 0.1)
    assert not est.valid and not est.in_air and est.hover_thrust != 0.40
    est.update(t + 2 * DT_US, False, True, 0.1, 0.0, 0.0, 0.0, 0.0)
    assert est.hover_thrust == 0.40


@pytest.mark.parametrize("name", ["x500-sprayer", "hex-sprayer"])
def test_closed_loop_hover_thrust_and_rotor_speed_match_the_hover_law(name: str) -> None:
    """Full tank (mass unknown to the autopilot, which starts from the empty mass): after the climb and
    a hold the estimate is m g / T_max within 1 %, and the mean rotor command is the hover speed."""
    v = vehicle(name)
    d, ap, tr = fly(v, MissionSpec(name="t", truth=True, phases=[{"type": "takeoff", "altitude_agl_m": 4.0},
                                                                  {"type": "hold", "duration_s": 12.0}]), 25)
    t_max = v.max_thrust()
    assert ap.hte.valid
    assert ap.hte.hover_thrust == pytest.approx(d.mass * G / t_max, rel=0.01)  # the ratio
    assert ap.status().extra["mass_est_kg"] == pytest.approx(d.mass, rel=0.01)
    assert v.dry_mass() * G / t_max < 0.75 * ap.hte.hover_thrust  # it started from the empty mass
    w_hover = v.hover_speed(d.mass)  # sqrt(m g / (n k_f))
    last = [statistics.fmean(w) for t, w in zip(tr.t, tr.w_cmd, strict=True) if t > tr.t[-1] - 4.0]
    assert statistics.fmean(last) == pytest.approx(w_hover, rel=0.01)


def test_closed_loop_follows_the_mass_as_the_tank_drains() -> None:
    """Spraying the 1 L tank empty in a hover over 50 s: the estimated mass follows the true one."""
    v = vehicle("x500-sprayer")
    d = RigidBodyDouble(v)
    ap = BuiltinAutopilot()
    ap.reset(d.context(MissionSpec(name="t", truth=True, phases=[
        {"type": "takeoff", "altitude_agl_m": 4.0}, {"type": "hold", "duration_s": 4.0},
        {"type": "sprayer", "flow_lps": 0.02}, {"type": "hold", "duration_s": 50.0}])))
    samples: list[tuple[float, float]] = []

    def sample(dd: RigidBodyDouble) -> None:
        if dd.t_us % 500_000 == 0 and dd.t_us > 8_000_000:
            samples.append((dd.mass, ap.mass))

    d.fly(ap, 65, on_step=sample)
    assert d.liquid_l < 0.01  # drained
    errors = [abs(est - true) / true for true, est in samples]
    assert max(errors) < 0.03
    assert samples[0][1] - samples[-1][1] > 0.9  # it learnt that (most of) the 1 kg of liquid left
