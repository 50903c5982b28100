"""Estimator convergence on synthetic sensor data (the real simulated sensors sampling a known
trajectory): attitude incl. heading, gyro bias, position and velocity."""

from __future__ import annotations

import math
from typing import Any

import pytest
from repo_paths import VEHICLES

from vinecli.autopilot.estimator import Estimator, periodic_gains
from vinecli.flight.sensors import make_sensors
from vinecli.frames import quat_from_euler, quat_mul, quat_to_euler
from vinecli.specs import load_spec
from vinecli.specs.vehicle import VehicleSpec
from vinecli.types import ImuSample, Observation, RigidState

from .rigid_body import ORIGIN

DT_US = 4000


def vehicle() -> VehicleSpec:
    return load_spec(VEHICLES / "x500.yaml", VehicleSpec)


def angle_between(q1: tuple[float, ...], q2: tuple[float, ...]) -> float:
    d = quat_mul((-q1[0], -q1[1], -q1[2], q1[3]), q2)
    return 2.0 * math.acos(min(1.0, abs(d[3])))


_SENSORS: dict[int, tuple[Estimator, object]] = {}


def run(est: Estimator, truth_at, seconds: float, *, seed: int = 3, gyro_bias: tuple[float, float, float] = (0.0, 0.0, 0.0),
        after_first=None, after_each=None, start_s: float = 0.0) -> RigidState:
    """Feed the estimator with the simulated sensors sampling ``truth_at(t)`` from start_s to seconds."""
    # one sensor set per estimator across calls (a compiled Estimator takes no new attributes)
    sensors = _SENSORS.setdefault(id(est), (est, make_sensors(vehicle().sensors, ORIGIN, seed)))[1]
    st = truth_at(0.0)
    for k in range(int(start_s * 1e6 / DT_US), int(seconds * 1e6 / DT_US)):
        st = truth_at(k * DT_US * 1e-6)
        st.t_us = k * DT_US
        imu, baro, mag, gnss = sensors.sample_all(st)
        g = imu.gyro_flu
        imu = ImuSample(imu.t_us, imu.accel_flu, (g[0] + gyro_bias[0], g[1] + gyro_bias[1], g[2] + gyro_bias[2]))
        est.update(Observation(st.t_us, st, imu, baro, mag, gnss))
        if k == 0 and after_first is not None:
            after_first(est)
        if after_each is not None:
            after_each(est)
    return st


def test_static_attitude_heading_and_position() -> None:
    q_true = quat_from_euler(0.08, -0.05, 2.2)
    pos = (3.0, -4.0, 1.5)

    def truth(t: float) -> RigidState:
        return RigidState(0, pos, q_true, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), False)

    est = Estimator(vehicle(), ORIGIN)
    run(est, truth, 6.0)
    assert est.ready
    assert math.degrees(angle_between(est.quat, q_true)) < 1.0
    assert abs(quat_to_euler(est.quat)[2] - 2.2) < math.radians(2.0)
    assert math.dist(est.pos[:2], pos[:2]) < 0.4  # GNSS sigma 0.3 m per axis, filtered
    assert est.pos[2] == pytest.approx(pos[2], abs=0.3)
    assert max(abs(v) for v in est.vel) < 0.15


def test_recovers_from_a_wrong_initial_attitude_and_learns_gyro_bias() -> None:
    q_true = quat_from_euler(0.0, 0.0, 0.5)

    def truth(t: float) -> RigidState:
        return RigidState(0, (0.0, 0.0, 0.2), q_true, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), True)

    def perturb(e: Estimator) -> None:
        e.quat = quat_from_euler(0.25, -0.2, 1.2)  # 15 deg tilt and 40 deg heading off

    est = Estimator(vehicle(), ORIGIN)
    bias = (0.01, -0.015, 0.008)
    run(est, truth, 40.0, gyro_bias=bias, after_first=perturb)
    assert math.degrees(angle_between(est.quat, q_true)) < 1.5
    # the integral terms learn the bias (tilt axes from the accelerometer, heading from the magnetometer)
    assert est.gyro_bias[:2] == pytest.approx(bias[:2], abs=0.003)
    assert est.gyro_bias[2] == pytest.approx(bias[2], abs=0.006)  # slower: heading loop gain is low


def test_tracks_an_accelerating_trajectory() -> None:
    # at rest for 2 s, then 1 m/s² east for 4 s, then 4 m/s; level, heading north
    q = quat_from_euler(0.0, 0.0, math.pi / 2)

    def truth(t: float) -> RigidState:
        if t < 2.0:
            x, vx, ax = 0.0, 0.0, 0.0
        elif t < 6.0:
            x, vx, ax = 0.5 * (t - 2.0) ** 2, t - 2.0, 1.0
        else:
            x, vx, ax = 8.0 + 4.0 * (t - 6.0), 4.0, 0.0
        return RigidState(0, (x, 0.0, 10.0), q, (vx, 0.0, 0.0), (0.0, 0.0, 0.0), (ax, 0.0, 0.0), False)

    est = Estimator(vehicle(), ORIGIN)
    worst_tilt = 0.0

    def check(e: Estimator) -> None:
        nonlocal worst_tilt
        r, p, _ = quat_to_euler(e.quat)
        worst_tilt = max(worst_tilt, abs(r), abs(p))

    st = run(est, truth, 4.5, after_each=check)
    assert est.vel[0] == pytest.approx(st.vel[0], abs=0.15)  # mid-acceleration
    assert est.acc[0] == pytest.approx(1.0, abs=0.25)
    st = run(est, truth, 10.0, after_each=check, start_s=4.5)
    assert est.vel[0] == pytest.approx(st.vel[0], abs=0.1)
    assert est.pos[0] == pytest.approx(st.pos[0], abs=0.4)
    # the GNSS-acceleration reference keeps the accelerometer from pulling the attitude
    assert math.degrees(worst_tilt) < 2.0


def test_periodic_gains_are_sane() -> None:
    # position-only measurements: a larger measurement noise gives smaller gains
    (k_lo,) = periodic_gains(0.004, 0.04, 4e-4, [(50.0, ((1.0, 0.0, 0.0),), (0.01,))], horizon_s=10.0)
    (k_hi,) = periodic_gains(0.004, 0.04, 4e-4, [(50.0, ((1.0, 0.0, 0.0),), (1.0,))], horizon_s=10.0)
    assert 0.0 < k_hi[0][0] < k_lo[0][0] < 1.0
    assert k_lo[1][0] > 0.0  # a position residual also corrects velocity


def test_periodic_gains_equal_the_step_by_step_riccati_iteration():
    """The period-compressed solver (predictions between corrections folded into F^m, Q_m, stopped
    at the periodic steady state) gives the gains of the plain step-by-step iteration over 30 s."""
    import numpy as np

    from vinecli.autopilot.estimator import periodic_gains

    dt, acc_psd, bias_psd = 0.004, 0.04, 0.0004
    sensors = [(50.0, ((1.0, 0.0, 0.0),), (0.007,)), (10.0, ((0.0, 1.0, 0.0),), (0.0025,))]
    f, q = _van_loan(dt, acc_psd, bias_psd)
    p = np.diag([100.0, 10.0, 1.0])
    ref = [None, None]
    for k in range(1, int(30.0 / dt) + 1):
        p = f @ p @ f.T + q
        for j, n in enumerate((5, 25)):
            if k % n == 0:
                h, r = np.array(sensors[j][1]), np.diag(sensors[j][2])
                kg = p @ h.T @ np.linalg.inv(h @ p @ h.T + r)
                p = (np.eye(3) - kg @ h) @ p
                p = 0.5 * (p + p.T)
                ref[j] = kg
    got = periodic_gains(dt, acc_psd, bias_psd, sensors)
    for g, rg in zip(got, ref, strict=True):
        assert np.allclose(np.array(g), rg, rtol=1e-10, atol=1e-14)
    assert periodic_gains(dt, acc_psd, bias_psd, sensors) == got  # cached, same values


@pytest.mark.parametrize(("dt", "acc_psd", "bias_psd"), [(0.004, 0.04, 4e-4), (0.02, 1.0, 1e-2), (1e-4, 0.3, 5e-6)])
def test_discrete_model_equals_the_van_loan_matrix_exponential(dt: float, acc_psd: float, bias_psd: float) -> None:
    """The closed-form F, Q equal scipy's Van Loan construction (expm of the 6x6 block matrix)."""
    import numpy as np

    from vinecli.autopilot.estimator import discrete_model

    f_ref, q_ref = _van_loan(dt, acc_psd, bias_psd)
    f, q = discrete_model(dt, acc_psd, bias_psd)
    assert np.allclose(f, f_ref, rtol=1e-14, atol=0.0)
    assert np.allclose(q, q_ref, rtol=1e-12, atol=0.0)
    assert np.array_equal(q, q.T)


def _van_loan(dt: float, acc_psd: float, bias_psd: float) -> tuple[Any, Any]:
    """(F, Q) of the estimator's (p, v, b) model by Van Loan's method: scipy's expm of the 6x6 block matrix."""
    import numpy as np
    from scipy.linalg import expm

    a = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, 0.0]])
    vl = np.zeros((6, 6))
    vl[:3, :3], vl[:3, 3:], vl[3:, 3:] = -a, np.diag([0.0, acc_psd, bias_psd]), a.T
    e = expm(vl * dt)
    f = e[3:, 3:].T
    q = f @ e[:3, 3:]
    return f, 0.5 * (q + q.T)
