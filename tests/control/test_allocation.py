"""Mixer: exact allocation when unsaturated (checked against the physics motor model), PX4
airmode-off desaturation priorities, rotor speed limits, torque signs."""

from __future__ import annotations

import math

import pytest
from repo_paths import VEHICLES

from vinecli.control.allocation import Mixer, effectiveness_matrix
from vinecli.errors import SpecError
from vinecli.flight.motor import MotorBank
from vinecli.specs import load_spec
from vinecli.specs.vehicle import VehicleSpec


def vehicle(name: str) -> VehicleSpec:
    return load_spec(VEHICLES / f"{name}.yaml", VehicleSpec)


def wrench_of(v: VehicleSpec, w: tuple[float, ...]) -> tuple[float, float, float, float]:
    """(thrust N, tx, ty, tz N m) produced by rotor speeds w, from the physics motor model."""
    bank = MotorBank(v.motor, v.rotors)
    bank.reset(w)
    f, t = bank.wrench(None)
    return (f[2], t[0], t[1], t[2])


@pytest.mark.parametrize("name", ["x500", "x500-sprayer", "hex-sprayer"])
@pytest.mark.parametrize("req_frac", [(1.0, 0.0, 0.0, 0.0), (1.0, 0.3, -0.2, 0.05), (0.8, -0.5, 0.4, -0.1), (1.3, 0.1, 0.6, 0.08)])
def test_unsaturated_allocation_is_exact(name: str, req_frac: tuple[float, float, float, float]) -> None:
    v = vehicle(name)
    mix = Mixer(v)
    hover = v.dry_mass() * 9.80665
    ts = mix.torque_scale
    req = (req_frac[0] * hover, req_frac[1] * ts[0] * 0.3, req_frac[2] * ts[1] * 0.3, req_frac[3] * ts[2] * 0.3)
    w = mix.allocate(*req)
    assert mix.saturation == (0, 0, 0, 0)
    got = wrench_of(v, w)
    for g, r in zip(got, req, strict=True):
        assert g == pytest.approx(r, abs=1e-9 + 1e-9 * abs(r))
    # speeds are sqrt(T / k_f)
    for wi, ti in zip(w, mix.thrusts, strict=True):
        assert wi == pytest.approx(math.sqrt(ti / v.motor.k_f))


def test_effectiveness_matrix_of_the_x500() -> None:
    v = vehicle("x500")
    b = effectiveness_matrix(v.motor, v.rotors)
    assert b.shape == (4, 4)
    # rotor 1 front-right CCW: thrust 1, roll = y = -0.174, pitch = -x = -0.174, yaw = -k_m
    assert tuple(b[:, 0]) == pytest.approx((1.0, -0.174, -0.174, -0.016))
    # rotor 3 front-left CW: yaw +k_m
    assert tuple(b[:, 2]) == pytest.approx((1.0, 0.174, -0.174, 0.016))


@pytest.mark.parametrize("name", ["x500", "hex-sprayer"])
def test_torque_signs(name: str) -> None:
    v = vehicle(name)
    mix = Mixer(v)
    hover = v.dry_mass() * 9.80665
    base = mix.allocate_thrusts(hover, 0.0, 0.0, 0.0)[:]
    roll = mix.allocate_thrusts(hover, 0.2, 0.0, 0.0)
    for r, t0, t1 in zip(v.rotors, base, roll, strict=True):
        y = r.position_m[1]
        if abs(y) > 1e-6:
            assert (t1 - t0) * y > 0  # +roll torque (about forward x): left rotors push more
    base = mix.allocate_thrusts(hover, 0.0, 0.0, 0.0)[:]
    pitch = mix.allocate_thrusts(hover, 0.0, 0.2, 0.0)
    for r, t0, t1 in zip(v.rotors, base, pitch, strict=True):
        x = r.position_m[0]
        if abs(x) > 1e-6:
            assert (t1 - t0) * x < 0  # +pitch torque (about left y, nose down): rear rotors push more
    yaw = mix.allocate_thrusts(hover, 0.0, 0.0, 0.05)
    for r, t0, t1 in zip(v.rotors, base, yaw, strict=True):
        assert (t1 - t0) * (-r.s) > 0  # +yaw torque (CCW): clockwise rotors push more


@pytest.mark.parametrize("name", ["x500", "hex-sprayer"])
def test_upper_saturation_keeps_roll_pitch_and_reduces_thrust(name: str) -> None:
    v = vehicle(name)
    mix = Mixer(v)
    t_total = mix.n * mix.t_max
    req_thrust = 0.95 * t_total
    tx, ty = 0.5 * mix.torque_scale[0], -0.3 * mix.torque_scale[1]
    w = mix.allocate(req_thrust, tx, ty, 0.0)
    got = wrench_of(v, w)
    assert got[1] == pytest.approx(tx, rel=1e-6)
    assert got[2] == pytest.approx(ty, rel=1e-6)
    assert got[0] < req_thrust - 1.0  # thrust gave way
    assert mix.saturation[0] == 1
    assert mix.saturation[1] == 0 and mix.saturation[2] == 0
    assert max(w) == pytest.approx(v.motor.w_max)
    assert all(v.motor.w_min_armed - 1e-9 <= wi <= v.motor.w_max + 1e-9 for wi in w)


def test_yaw_has_the_lowest_priority() -> None:
    v = vehicle("x500")
    mix = Mixer(v)
    hover = v.dry_mass() * 9.80665
    tx = 0.6 * mix.torque_scale[0]
    tz = 3.0 * mix.torque_scale[2]  # far beyond what is available
    w = mix.allocate(hover, tx, 0.0, tz)
    got = wrench_of(v, w)
    assert got[1] == pytest.approx(tx, rel=1e-6)  # roll kept
    assert 0.0 < got[3] < tz  # yaw reduced, same sign
    assert mix.saturation[3] == 1


def test_lower_saturation_reduces_roll_not_thrust_up() -> None:
    # airmode off: at low collective thrust a large roll request is scaled down; thrust is never raised
    v = vehicle("x500")
    mix = Mixer(v)
    low = 1.05 * mix.n * mix.t_min
    tx = 1.0 * mix.torque_scale[0]
    w = mix.allocate(low, tx, 0.0, 0.0)
    got = wrench_of(v, w)
    assert got[0] <= low + 1e-6
    assert 0.0 < got[1] < tx
    assert mix.saturation[1] == 1
    assert min(w) == pytest.approx(v.motor.w_min_armed)


def test_speed_commands_are_clamped() -> None:
    v = vehicle("x500")
    mix = Mixer(v)
    assert mix.rotor_speeds([0.0, -1.0, 1e9, mix.t_max]) == pytest.approx(
        (v.motor.w_min_armed, v.motor.w_min_armed, v.motor.w_max, v.motor.w_max))


def test_rotor_layout_without_yaw_authority_is_rejected() -> None:
    v = vehicle("x500")
    same = [r.model_copy(update={"spin": "ccw"}) for r in v.rotors]
    with pytest.raises(SpecError, match="cannot control"):
        Mixer(v.model_copy(update={"rotors": same}))
