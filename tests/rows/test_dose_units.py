"""Dose expressions against the worked examples of the sources (vinecli.rows.dose_units, docs/dose.md)."""

from __future__ import annotations

import math

import pytest

from vinecli.rows.dose_units import (
    DoseExpr,
    lwa_dose_from_rate,
    lwa_m2_per_ha,
    rate_from_lwa_dose,
    rate_from_trv_dose,
    rate_lpha,
    row_litres_per_m,
    trv_m3_per_ha,
)


def test_lwa_of_the_eppo_example() -> None:
    """EPPO PP 1/239(3) (the spray notes' example): 2.5 m rows, 1.2 m foliage, both sides: 9,600 m²/ha; one side
    half of it."""
    assert lwa_m2_per_ha(2.5, 1.2, 2) == pytest.approx(9600.0)
    assert lwa_m2_per_ha(2.5, 1.2, 1) == pytest.approx(4800.0)


def test_lwa_of_the_central_zone_reference_vineyard() -> None:
    """The leaf wall area grows with the wall and shrinks with the spacing: 3.0 m rows with a 1.5 m wall (both
    sides) is 10,000 m²/ha, the reference hectare of a dose 'per 10,000 m² LWA'."""
    assert lwa_m2_per_ha(3.0, 1.5) == pytest.approx(10_000.0)
    assert rate_from_lwa_dose(300.0, lwa_m2_per_ha(3.0, 1.5)) == pytest.approx(300.0)


def test_trv_example() -> None:
    """TRV = height x width x 10,000 / spacing: 2.5 m rows, 1.2 m high, 0.5 m wide: 2,400 m³/ha."""
    assert trv_m3_per_ha(2.5, 1.2, 0.5) == pytest.approx(2400.0)


def test_label_dose_to_ground_rate_and_back() -> None:
    """200 L per 10,000 m² LWA on 9,600 m²/ha is 192 L/ha of ground; and back."""
    lwa = lwa_m2_per_ha(2.5, 1.2)
    assert rate_from_lwa_dose(200.0, lwa) == pytest.approx(192.0)
    assert lwa_dose_from_rate(192.0, lwa) == pytest.approx(200.0)
    assert math.isnan(lwa_dose_from_rate(100.0, 0.0))


def test_trv_dose_to_ground_rate() -> None:
    """A dose per 10,000 m³ TRV scales with the hedge volume: 500 L on 2,400 m³/ha is 120 L/ha."""
    assert rate_from_trv_dose(500.0, trv_m3_per_ha(2.5, 1.2, 0.5)) == pytest.approx(120.0)


def test_a_thin_canopy_gets_less_and_a_gap_nothing() -> None:
    lwa = DoseExpr("lwa", 200.0)
    full, thin, none = (rate_lpha(lwa, 2.5, h, 0.5) for h in (1.2, 0.6, 0.0))
    assert full == pytest.approx(192.0) and thin == pytest.approx(96.0) and none == 0.0
    assert rate_lpha(DoseExpr("rate", 150.0), 2.5, 0.0, 0.0) == 150.0  # a rate is a rate
    assert rate_lpha(DoseExpr("lwa", 200.0, sides=1), 2.5, 1.2, 0.5) == pytest.approx(96.0)


def test_litres_per_metre_of_row() -> None:
    """A metre of row in 2.5 m rows stands for 2.5 m² of ground: 200 L/ha is 0.05 L per metre of row."""
    assert row_litres_per_m(200.0, 2.5) == pytest.approx(0.05)


@pytest.mark.parametrize("bad", [{"kind": "ha", "value": 1.0}, {"kind": "lwa", "value": -1.0},
                                 {"kind": "lwa", "value": math.nan}, {"kind": "lwa", "value": 1.0, "sides": 3}])
def test_bad_dose_refused(bad: dict) -> None:
    with pytest.raises(ValueError):
        DoseExpr(**bad)
    with pytest.raises(ValueError):
        lwa_m2_per_ha(0.0, 1.2)
