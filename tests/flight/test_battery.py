"""Battery model (flight/battery.py) against its formulas and published figures."""

from __future__ import annotations

import math

import pytest

from vinecli.flight.battery import Battery, ElectricalLoad, ocv_chen_rincon_mora
from vinecli.specs.vehicle import BatterySpec
from vinecli.vehicle import load_vehicle

RHO = 1.225  # kg/m³, ISA sea level


def _spec(**kw: object) -> BatterySpec:
    d: dict[str, object] = {"cells": 4, "capacity_wh": 74.0, "internal_resistance_ohm_per_cell": 0.005}
    d.update(kw)
    return BatterySpec.model_validate(d)


def test_ocv_curve_matches_chen_rincon_mora_points() -> None:
    """Published fit: 4.10 V full, ~3.80 V at half, 2.65 V empty; monotonic."""
    assert ocv_chen_rincon_mora(1.0) == pytest.approx(4.1029, abs=1e-3)
    assert ocv_chen_rincon_mora(0.5) == pytest.approx(3.8034, abs=1e-3)
    assert ocv_chen_rincon_mora(0.0) == pytest.approx(2.654, abs=1e-3)
    vs = [ocv_chen_rincon_mora(i / 100) for i in range(101)]
    assert all(b > a for a, b in zip(vs, vs[1:], strict=False))


def test_terminal_voltage_sags_by_i_r_and_power_balances() -> None:
    b = Battery(_spec())
    e = b.open_circuit_v()
    b.update(600.0, 0.01)
    r = 4 * 0.005
    assert b.voltage_v == pytest.approx(e - b.current_a * r, rel=1e-12)
    assert b.voltage_v * b.current_a == pytest.approx(600.0, rel=1e-9)  # the load got its power
    assert b.power_drawn_w == pytest.approx(600.0 + b.current_a**2 * r, rel=1e-9)  # + I²R heat
    v_light = Battery(_spec())
    v_light.update(100.0, 0.01)
    assert v_light.voltage_v > b.voltage_v  # more load, more sag


def test_energy_drawn_equals_capacity_times_soc_drop() -> None:
    b = Battery(_spec())
    drawn = 0.0
    for k in range(20000):
        b.update(500.0 + 200.0 * math.sin(k * 0.01), 0.02)
        drawn += b.power_drawn_w * 0.02
    assert drawn / 3600.0 == pytest.approx(74.0 * (1.0 - b.soc), rel=1e-9)
    assert 0.0 < b.soc < 0.9


def test_overload_is_capped_at_the_pack_maximum_power() -> None:
    b = Battery(_spec(internal_resistance_ohm_per_cell=0.5))
    p_max = b.max_power_w()
    b.update(10 * p_max, 0.01)
    assert b.saturated and b.load_w == pytest.approx(p_max)
    assert b.voltage_v == pytest.approx(b.open_circuit_v() / 2, rel=1e-6)  # matched load


def test_ocv_table_and_threshold_order_validated() -> None:
    b = Battery(_spec(ocv_table=[(0.0, 3.3), (0.5, 3.8), (1.0, 4.2)]))
    assert b.ocv_cell(0.75) == pytest.approx(4.0)
    with pytest.raises(ValueError, match="ascending"):
        _spec(ocv_table=[(0.5, 3.8), (0.0, 3.3), (1.0, 4.2)])
    with pytest.raises(ValueError, match="emergency_soc"):
        _spec(low_soc=0.05, critical_soc=0.1)


def test_electrical_load_adds_motor_losses_avionics_and_pump() -> None:
    s = _spec(motor_efficiency=0.8, avionics_w=10.0, pump_w_at_max_flow=24.0)
    load = ElectricalLoad(s, 0.1)
    assert load.pump_w(0.05) == pytest.approx(24.0 * 0.05 / 0.1) and load.pump_w(0.0) == 0.0
    assert load.power_w(400.0, 0.05) == pytest.approx(400.0 / 0.8 + 10.0 + 12.0, rel=1e-15)
    assert ElectricalLoad(s, None).power_w(400.0, 0.0) == pytest.approx(400.0 / 0.8 + 10.0)  # no tank, no pump


@pytest.mark.parametrize("name", ["x500", "x500-sprayer", "hex-sprayer"])
def test_shipped_rotors_have_a_published_figure_of_merit(name: str) -> None:
    """Hover: ideal power T^1.5 / sqrt(2 rho A) over shaft power k_m T w = FoM, which for these rotor
    constants is sqrt(k_f) / (k_m sqrt(2 rho A)) whatever the thrust; small multirotors: 0.5-0.75."""
    v = load_vehicle(name)
    m = v.motor
    t = v.dry_mass() * 9.80665 / v.n_rotors
    w = math.sqrt(t / m.k_f)
    fom = t**1.5 / math.sqrt(2 * RHO * m.disk_area_m2()) / (m.k_m * t * w)
    assert 0.5 <= fom <= 0.75, fom
    assert v.battery is not None
