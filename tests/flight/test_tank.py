"""Tank: weight at rest, drain time, clamps, inertial force, and the slosh pendulum."""

from __future__ import annotations

import math

import pytest

from vinecli.errors import SpecError
from vinecli.flight.tank import XI1, Tank, TankCoupling, contact_force, mount_acceleration, slosh_parameters
from vinecli.frames import BodyFrame
from vinecli.specs.vehicle import TankSpec

G = (0.0, 0.0, -9.80665)
SPEC = TankSpec(capacity_l=1.0, nozzle_max_flow_lps=0.1)


def test_force_at_rest_is_liquid_weight() -> None:
    tank = Tank(SPEC, 1.0)
    assert tank.mass_kg == pytest.approx(1.0)
    assert tank.level_l == pytest.approx(1.0)
    f = tank.force_world(G, (0.0, 0.0, 0.0))
    assert f[2] == pytest.approx(-9.80665, rel=0.005)
    assert f[2] == pytest.approx(-9.80665, rel=1e-12)
    assert f[0] == 0.0 and f[1] == 0.0
    assert tank.gravity_force == pytest.approx((0.0, 0.0, -9.80665))
    assert tank.inertial_force == pytest.approx((0.0, 0.0, 0.0))


def test_force_jumps_at_liftoff_and_returns_in_steady_climb() -> None:
    tank = Tank(SPEC, 1.0)
    f = tank.force_world(G, (0.0, 0.0, 3.0))  # accelerating upwards at lift-off
    assert f[2] == pytest.approx(-(9.80665 + 3.0))
    assert tank.inertial_force[2] == pytest.approx(-3.0)
    assert tank.gravity_force[2] == pytest.approx(-9.80665)
    f = tank.force_world(G, (0.0, 0.0, 0.0))  # steady climb: a = 0
    assert f[2] == pytest.approx(-9.80665)
    f = tank.force_world(G, (2.0, -1.0, 0.0))  # horizontal acceleration: liquid pushes backwards
    assert f[0] == pytest.approx(-2.0) and f[1] == pytest.approx(1.0)


@pytest.mark.parametrize("flow,dt", [(0.05, 0.004), (0.1, 0.004), (0.03, 0.01), (0.0123, 0.004)])
def test_drain_time_is_volume_over_flow(flow: float, dt: float) -> None:
    tank = Tank(SPEC, 0.8)
    t = 0.0
    levels = []
    while not tank.empty:
        tank.update(flow, dt)
        t += dt
        levels.append(tank.level_l)
        assert tank.mass_kg >= 0.0
        assert t < 100.0
    assert abs(t - 0.8 / flow) <= dt + 1e-9
    # level falls linearly at the commanded rate
    assert levels[0] == pytest.approx(0.8 - flow * dt)
    assert levels[9] == pytest.approx(0.8 - 10 * flow * dt)
    assert all(b <= a for a, b in zip(levels, levels[1:], strict=False))


def test_drain_residue_snaps_to_exactly_empty() -> None:
    """1 L at 0.02 L/s in 4 ms steps: 12500 subtractions leave ~1e-13 L of rounding residue without the
    snap; the tank must be exactly empty after volume / flow (and not one step earlier)."""
    tank = Tank(SPEC, 1.0)
    n = round(1.0 / 0.02 / 0.004)
    for _ in range(n - 1):
        tank.update(0.02, 0.004)
    assert not tank.empty and tank.level_l == pytest.approx(0.02 * 0.004, rel=1e-6)
    tank.update(0.02, 0.004)
    assert tank.empty and tank.mass_kg == 0.0 and tank.level_l == 0.0
    assert tank.flow_lps == pytest.approx(0.02, rel=1e-6)


def test_never_negative_and_flow_zero_when_empty() -> None:
    tank = Tank(SPEC, 0.01)
    tank.update(0.1, 1.0)  # asks for 0.1 L with 0.01 L left
    assert tank.mass_kg == 0.0 and tank.level_l == 0.0 and tank.empty
    assert tank.flow_lps == pytest.approx(0.01)  # actual flow this step: what was left
    tank.update(0.1, 0.004)
    assert tank.mass_kg == 0.0 and tank.flow_lps == 0.0
    assert tank.force_world(G, (0.0, 0.0, 5.0)) == (0.0, 0.0, 0.0)


def test_flow_clamped_to_nozzle_max_and_non_negative() -> None:
    tank = Tank(SPEC, 1.0)
    tank.update(5.0, 0.5)  # 5 L/s asked, nozzle gives 0.1
    assert tank.flow_lps == pytest.approx(0.1)
    assert tank.flow_cmd_lps == 5.0
    assert tank.level_l == pytest.approx(1.0 - 0.05)
    tank.update(-1.0, 0.5)
    assert tank.flow_lps == 0.0 and tank.level_l == pytest.approx(0.95)


def test_density_and_fill_validation() -> None:
    oil = Tank(TankSpec(capacity_l=2.0, nozzle_max_flow_lps=0.1, liquid_density_kgm3=900.0), 2.0)
    assert oil.mass_kg == pytest.approx(1.8)
    assert oil.force_world(G, (0.0, 0.0, 0.0))[2] == pytest.approx(-1.8 * 9.80665)
    with pytest.raises(SpecError):
        Tank(SPEC, 1.5)
    with pytest.raises(SpecError):
        Tank(SPEC, -0.1)


def test_slosh_parameters_limits() -> None:
    # deep tank: m1/m -> 2 R / (ξ (ξ²-1) h), L1 -> R/ξ
    cap, height = 1.0, 2.0
    r = math.sqrt(cap * 1e-3 / height / math.pi)
    frac, length, w = slosh_parameters(1.0, cap, height)
    h = height
    assert frac == pytest.approx(2 * r / (XI1 * (XI1**2 - 1) * h), rel=1e-3)
    assert length == pytest.approx(r / XI1, rel=1e-3)
    assert w == pytest.approx(math.sqrt(9.80665 / length))
    # shallow fill: the sloshing share grows, the pendulum lengthens (slower mode)
    frac2, length2, w2 = slosh_parameters(0.05, cap, height)
    assert frac2 > frac and length2 > length and w2 < w


def test_slosh_at_rest_equals_weight_and_oscillates_at_first_mode() -> None:
    spec = TankSpec(capacity_l=1.0, nozzle_max_flow_lps=0.1, slosh=True, slosh_damping_ratio=0.02, tank_height_m=0.12)
    tank = Tank(spec, 1.0)
    dt = 0.001
    for _ in range(100):
        tank.update(0.0, dt)
        f = tank.force_world(G, (0.0, 0.0, 0.0))
    assert f == pytest.approx((0.0, 0.0, -9.80665), abs=1e-12)
    # step in horizontal acceleration: the liquid swings at ω1 and settles to m (g - a)
    frac, _length, w1 = slosh_parameters(1.0, 1.0, 0.12)
    fx = []
    for _ in range(20000):
        tank.update(0.0, dt)
        fx.append(tank.force_world(G, (1.0, 0.0, 0.0))[0])
    base = -1.0  # -m a_x
    dev = [x - base for x in fx]
    assert abs(dev[0]) > 0.5 * frac * 1.0  # the bob lags: the force jumps less than m a at first
    crossings = [i for i in range(1, 3000) if dev[i - 1] * dev[i] < 0]
    period = 2 * (crossings[-1] - crossings[0]) * dt / (len(crossings) - 1)
    assert period == pytest.approx(2 * math.pi / w1, rel=0.03)
    assert abs(dev[-1]) < 1e-3  # damped out
    assert fx[-1] == pytest.approx(-1.0, abs=1e-3)
    assert tank.slosh_displacement[0] == pytest.approx(-1.0 / w1**2, rel=0.01)  # bob hangs back


def test_no_slosh_force_when_disabled() -> None:
    tank = Tank(SPEC, 1.0)
    tank.update(0.0, 0.004)
    tank.force_world(G, (3.0, 0.0, 0.0))
    assert tank.slosh_force == (0.0, 0.0, 0.0)


def test_contact_force_from_the_finite_difference_acceleration() -> None:
    """F_c = M (a - g) - F_ext - F_tank: at rest (a = 0, no thrust) the ground carries the rigid weight
    and the liquid's push; in free fall (a = g) there is none."""
    m, f_tank = 2.3, (0.0, 0.0, -9.80665)
    assert contact_force(m, (0.0, 0.0, 0.0), G, (0.0, 0.0, 0.0), f_tank) == pytest.approx((0.0, 0.0, m * 9.80665 + 9.80665))
    assert contact_force(m, G, G, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)) == (0.0, 0.0, 0.0)
    assert contact_force(m, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.5, 0.0, 0.0), (0.2, 0.0, 0.0)) == pytest.approx((1.6, 0, 0))


def test_mount_acceleration_is_rigid_body_kinematics() -> None:
    """a = (F + F_c) / (M + m) + g + α × r + ω × (ω × r)."""
    f, fc, inv_m = (3.0, -1.0, 40.0), (0.0, 0.0, -5.0), 1.0 / 3.3
    alpha, omega, r = (0.5, -0.2, 0.1), (0.3, 0.4, -1.0), (0.01, -0.02, -0.06)

    def cross(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float]:
        return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

    want = tuple((fi + ci) * inv_m + gi + ai + wi for fi, ci, gi, ai, wi in
                 zip(f, fc, G, cross(alpha, r), cross(omega, cross(omega, r)), strict=True))
    assert mount_acceleration(f, fc, inv_m, G, alpha, omega, r) == pytest.approx(want, rel=1e-12)
    # spinning about z at ω, a mount at radius R feels the centripetal ω² R towards the axis
    a = mount_acceleration((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 2.0),
                           (0.5, 0.0, 0.0))
    assert a == pytest.approx((-2.0, 0.0, 0.0))


def test_coupling_gives_the_weight_at_rest_and_nothing_in_free_fall() -> None:
    frame = BodyFrame()
    still = (0.0, 0.0, 0.0)
    rest = TankCoupling(Tank(SPEC, 1.0), 2.3, G, airborne=False)
    for _ in range(3):  # at rest the finite-difference acceleration is zero and no other force acts
        f, r = rest.force(frame, still, still, still, still)
        assert f == pytest.approx((0.0, 0.0, -9.80665)) and r == SPEC.mount_m
    fall = TankCoupling(Tank(SPEC, 1.0), 2.3, G, airborne=True)
    f, _ = fall.force(frame, still, still, still, still)
    assert f == pytest.approx((0.0, 0.0, 0.0))
    f, _ = fall.force(frame, G, still, still, still)  # falling: a = g, no contact
    assert f == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
