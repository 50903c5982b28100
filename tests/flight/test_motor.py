"""MotorBank: hover speed, first-order lag, rotor drag, rolling moment, reaction torque signs."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from vinecli.flight.motor import MotorBank
from vinecli.frames import quat_from_euler, quat_rotate_inv
from vinecli.specs import load_spec
from vinecli.specs.vehicle import MotorSpec, RotorSpec, VehicleSpec

G = 9.80665
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module", params=["x500", "x500-sprayer", "hex-sprayer"])
def vehicle(request: pytest.FixtureRequest, repo) -> VehicleSpec:
    return load_spec(repo / "vehicles" / f"{request.param}.yaml", VehicleSpec)


def _bank(**kw: float) -> MotorBank:
    m = dict(k_f=8.54858e-6, k_m=0.016, k_d=8.06428e-5, k_roll=1e-6, w_max=1000.0, tau_up_s=0.0125, tau_down_s=0.025)
    m.update(kw)
    rotors = [RotorSpec(position_m=(0.2, -0.1, 0.05), spin="ccw")]
    return MotorBank(MotorSpec(**m), rotors)


def test_hover_speed_balances_weight(vehicle: VehicleSpec) -> None:
    mass = vehicle.dry_mass() + vehicle.liquid_mass(vehicle.tank.capacity_l if vehicle.tank else 0.0)
    bank = MotorBank(vehicle.motor, vehicle.rotors)
    w_h = math.sqrt(mass * G / (vehicle.n_rotors * vehicle.motor.k_f))
    assert bank.hover_speed(mass) == pytest.approx(w_h, rel=1e-12)
    assert w_h < vehicle.motor.w_max, "vehicle cannot hover"
    for _ in range(1000):  # 4 s at 250 Hz: steady state of the lag
        bank.update([w_h] * bank.n, 0.004)
    force, torque = bank.wrench(None)
    assert all(w == pytest.approx(w_h, rel=1e-6) for w in bank.w)
    assert force[2] == pytest.approx(mass * G, rel=0.005)
    assert abs(force[0]) < 1e-9 and abs(force[1]) < 1e-9
    assert bank.thrust_total == pytest.approx(mass * G, rel=0.005)
    # symmetric frame with balanced spins: no net torque at hover
    assert max(abs(t) for t in torque) < 1e-9


@pytest.mark.parametrize("dt", [0.0125, 0.0025, 0.00125, 0.0125 / 7])
def test_lag_reaches_63_percent_at_tau_up(dt: float) -> None:
    """Exact discretisation: 63.2 % of the step at t = tau_up whatever the step size."""
    bank = _bank()
    bank.reset(100.0)
    for _ in range(round(0.0125 / dt)):
        bank.update([900.0], dt)
    assert (bank.w[0] - 100.0) / 800.0 == pytest.approx(1 - math.exp(-1.0), abs=1e-9)
    assert (bank.w[0] - 100.0) / 800.0 == pytest.approx(0.632, abs=0.001)


def test_lag_reaches_63_percent_at_tau_down() -> None:
    bank = _bank()
    bank.reset(900.0)
    for _ in range(25):  # 25 ms = tau_down at 1 kHz
        bank.update([100.0], 0.001)
    assert (900.0 - bank.w[0]) / 800.0 == pytest.approx(0.632, abs=0.001)
    # and spin-up uses the faster constant: after the same time it is further
    up = _bank()
    up.reset(100.0)
    for _ in range(25):
        up.update([900.0], 0.001)
    assert (up.w[0] - 100.0) / 800.0 == pytest.approx(1 - math.exp(-2.0), abs=0.001)


def test_speed_clamped_to_range() -> None:
    bank = _bank()
    for _ in range(200):
        bank.update([5000.0], 0.004)
    assert bank.w[0] == pytest.approx(1000.0, abs=1e-6) and bank.w[0] <= 1000.0
    for _ in range(200):
        bank.update([-50.0], 0.004)
    assert 0.0 <= bank.w[0] < 1e-6
    bank.reset(1e9)
    assert bank.w[0] == 1000.0


def test_rotor_drag_linear_in_w_and_vperp_and_opposes_motion() -> None:
    bank = _bank(k_roll=0.0)
    bank.reset(500.0)
    # rotor moving +x through still air: apparent air (wind - v) = -x
    bank.wrench([(-2.0, 0.0, 0.0)])
    d1 = bank.rotor_drag_body
    assert d1[0] == pytest.approx(-8.06428e-5 * 500.0 * 2.0, rel=1e-12)
    assert d1[1] == 0.0 and d1[2] == 0.0
    bank.wrench([(-4.0, 0.0, 0.0)])
    assert bank.rotor_drag_body[0] == pytest.approx(2 * d1[0], rel=1e-12)
    bank.reset(1000.0)
    bank.wrench([(-2.0, 0.0, 0.0)])
    assert bank.rotor_drag_body[0] == pytest.approx(2 * d1[0], rel=1e-12)
    # wind from +y pushing on a hovering rotor: drag along the wind (+y)
    bank.wrench([(0.0, 3.0, 0.0)])
    assert bank.rotor_drag_body[1] > 0 and bank.rotor_drag_body[0] == 0.0
    # the axial component produces no H-force
    bank.wrench([(0.0, 0.0, -7.0)])
    assert bank.rotor_drag_body == (0.0, 0.0, 0.0)
    # and it shows in the total force next to the thrust
    force, _ = bank.wrench([(-2.0, 1.0, 5.0)])
    assert force[0] == pytest.approx(-8.06428e-5 * 1000.0 * 2.0)
    assert force[1] == pytest.approx(8.06428e-5 * 1000.0 * 1.0)
    assert force[2] == pytest.approx(8.54858e-6 * 1000.0**2)


def test_rolling_moment_linear_and_along_minus_vperp() -> None:
    bank = _bank(k_d=0.0, k_m=0.0)
    bank.reset(400.0)
    bank.wrench([(-3.0, 0.0, 0.0)])  # rotor moves +x through the air: V⊥ = +x
    m1 = bank.rolling_moment_body
    assert m1[0] == pytest.approx(-1e-6 * 400.0 * 3.0, rel=1e-12) and m1[1] == 0.0 and m1[2] == 0.0
    bank.reset(800.0)
    bank.wrench([(-6.0, 0.0, 0.0)])
    assert bank.rolling_moment_body[0] == pytest.approx(4 * m1[0], rel=1e-12)
    bank.wrench([(0.0, 0.0, 9.0)])
    assert bank.rolling_moment_body == (0.0, 0.0, 0.0)


def test_rolling_moment_enters_total_torque() -> None:
    """Torque = r × F + reaction torque + rolling moment, term by term."""
    bank = _bank(k_d=0.0)
    bank.reset(600.0)
    _, torque = bank.wrench([(-5.0, 2.0, 0.0)])
    t = 8.54858e-6 * 600.0**2
    px, py = 0.2, -0.1
    roll = (1e-6 * 600.0 * -5.0, 1e-6 * 600.0 * 2.0, 0.0)
    assert torque[0] == pytest.approx(py * t + roll[0], rel=1e-12)
    assert torque[1] == pytest.approx(-px * t + roll[1], rel=1e-12)
    assert torque[2] == pytest.approx(-0.016 * t, rel=1e-12)


def test_yaw_command_turns_the_right_way(vehicle: VehicleSpec) -> None:
    """Speeding up the CCW rotors (s = +1) yaws the body clockwise seen from above (-z in FLU)."""
    bank = MotorBank(vehicle.motor, vehicle.rotors)
    mass = vehicle.dry_mass()
    w_h = bank.hover_speed(mass)
    cmd = [w_h * (1.1 if r.spin == "ccw" else 0.9) for r in vehicle.rotors]
    for _ in range(200):
        bank.update(cmd, 0.004)
    _, torque = bank.wrench(None)
    assert torque[2] < 0
    assert bank.reaction_torque_body[2] == pytest.approx(torque[2])
    # no roll/pitch from a pure yaw command on a symmetric frame
    assert abs(torque[0]) < 1e-9 and abs(torque[1]) < 1e-9
    # integrate the yaw rate: the heading decreases (turns right)
    r, yaw = 0.0, 0.0
    for _ in range(100):
        r += torque[2] / vehicle.frame.inertia_kgm2[2] * 0.004
        yaw += r * 0.004
    assert yaw < -1e-3
    # a single CCW rotor alone reacts with exactly -k_m T about +z
    one = MotorBank(vehicle.motor, [RotorSpec(position_m=(0.0, 0.0, 0.0), spin="ccw")])
    one.reset(700.0)
    _, tq = one.wrench(None)
    assert tq[2] == pytest.approx(-vehicle.motor.k_m * vehicle.motor.k_f * 700.0**2)


def test_roll_and_pitch_from_differential_thrust() -> None:
    spec = load_spec(REPO / "vehicles" / "x500.yaml", VehicleSpec)
    bank = MotorBank(spec.motor, spec.rotors)
    left = [800.0 if r.position_m[1] > 0 else 700.0 for r in spec.rotors]
    bank.reset(0.0)
    for _ in range(500):
        bank.update(left, 0.004)
    _, torque = bank.wrench(None)
    assert torque[0] > 0  # left side up -> positive roll about +x (FLU)
    front = [800.0 if r.position_m[0] > 0 else 700.0 for r in spec.rotors]
    for _ in range(500):
        bank.update(front, 0.004)
    _, torque = bank.wrench(None)
    assert torque[1] < 0  # nose up is negative pitch about +y (y left)


def test_apparent_air_at_rotors() -> None:
    spec = load_spec(REPO / "vehicles" / "x500.yaml", VehicleSpec)
    bank = MotorBank(spec.motor, spec.rotors)
    q = quat_from_euler(0.0, 0.0, math.pi / 2)  # nose north
    v = bank.apparent_air_body(q, (0.0, 3.0, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    # flying north at 3 m/s, 1 m/s wind towards east: air from the nose (-x), pushed to the right (east = body -y)
    for va in v:
        assert va == pytest.approx((-3.0, -1.0, 0.0))
    # pure yaw rate: rotor at (x, y) moves with ω × r; apparent air is its negative
    v = bank.apparent_air_body((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 2.0), (0.0, 0.0, 0.0))
    for (px, py, _), va in zip(bank.positions, v, strict=True):
        assert va == pytest.approx((2.0 * py, -2.0 * px, 0.0))


@pytest.mark.parametrize("name", ["x500", "hex-sprayer"])
def test_wrench_com_equals_the_general_path(name: str) -> None:
    """The loop's form (air at the CoM and body rates) gives bit for bit the per-rotor formulas (random states)."""
    import random

    rng = random.Random(4)
    spec = load_spec(REPO / "vehicles" / f"{name}.yaml", VehicleSpec)
    bank = MotorBank(spec.motor, spec.rotors)
    for _ in range(50):
        bank.reset([rng.uniform(0.0, spec.motor.w_max) for _ in range(bank.n)])
        q = quat_from_euler(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-3, 3))
        vel = (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5))
        omega = (rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3))
        wind = (rng.uniform(-8, 8), rng.uniform(-8, 8), 0.0)
        f1, t1 = bank.wrench(bank.apparent_air_body(q, vel, omega, wind))
        rec1 = (bank.rotor_drag_body, bank.reaction_torque_body, bank.rolling_moment_body, bank.thrust_total)
        b = quat_rotate_inv(q, (wind[0] - vel[0], wind[1] - vel[1], wind[2] - vel[2]))
        f2, t2 = bank.wrench_com(*b, *omega)
        rec2 = (bank.rotor_drag_body, bank.reaction_torque_body, bank.rolling_moment_body, bank.thrust_total)
        assert (f2, t2, rec2) == (f1, t1, rec1)


def test_tilted_rotor_axis_general_path() -> None:
    """A rotor tilted 90° (axis body +x) pushes forward and reacts about x."""
    motor = MotorSpec(k_f=1e-5, k_m=0.02, k_d=1e-4, w_max=1000.0, tau_up_s=0.01, tau_down_s=0.02)
    bank = MotorBank(motor, [RotorSpec(position_m=(0.0, 0.0, 0.0), spin="cw", axis=(2.0, 0.0, 0.0))])
    bank.reset(500.0)
    f, t = bank.wrench_com(0.0, 0.0, 4.0, 0.0, 0.0, 0.0)  # at rest, wind 4 m/s from below
    assert f[0] == pytest.approx(2.5)
    assert f[2] == pytest.approx(1e-4 * 500.0 * 4.0)  # wind from below is in this rotor's plane
    assert t[0] == pytest.approx(+0.02 * 2.5)  # CW: s = -1 -> +k_m T along the axis
