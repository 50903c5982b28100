"""The spray budget moves the way field trials report (docs/budget.md): more wind, finer drops or a higher flight
give more drift; a denser canopy catches more and leaves less on the ground. Every budget balances.

Each case is a trial (vinecli.spray.spray_trial): a hexacopter (M600-class, 15 kg) sprays along all five
rows of a vineyard (2.5 m apart, 40 m long, VSP hedges) in a crosswind blowing out over the last row,
through the same transport, outwash, interception, evaporation and drift code every run uses.
"""

from __future__ import annotations

import pytest

from vinecli.spray.spray_trial import Trial, TrialVehicle, run_trial, vineyard_rows

ROWS = vineyard_rows(5, 2.5, 40.0)
PASSES = [((x, 0.0), (x, 40.0)) if i % 2 == 0 else ((x, 40.0), (x, 0.0)) for i, x in enumerate((0, 2.5, 5, 7.5, 10))]
BASE = dict(vmd=145.0, wind=2.0, height=3.0, lad=4.6)


def budget(**over: float):
    c = {**BASE, **over}
    veh = TrialVehicle(mass_kg=15.0, n_rotors=6, prop_diameter_m=0.533,
                       nozzles_flu=((0.455, 0.0, -0.175), (-0.455, 0.0, -0.175)), cone_angle_deg=80.0,
                       vmd_um=c["vmd"], gsd=1.8)
    trial = Trial(vehicle=veh, rows=ROWS, passes=PASSES, height_m=c["height"], speed_mps=3.0, flow_lps=0.04,
                  applied_lpha=0.04 * 1e4 / (3.0 * 2.5), wind_enu=(c["wind"], 0.0, 0.0),
                  hedge=(0.53, 2.21, 0.55, c["lad"]), air=(20.0, 60.0))
    b, _ = run_trial(trial)
    assert b.balance_error <= 1e-9
    assert sum(b.fractions.values()) == pytest.approx(1.0, abs=1e-9)
    return b


def drift(b) -> float:
    """Sedimenting drift plus what leaves the drift domain airborne: everything off the field."""
    return b.fractions["ground_off_field"] + b.fractions["airborne_out"]


@pytest.fixture(scope="module")
def base():
    return budget()


def test_more_wind_more_drift(base):
    calm, windy = budget(wind=0.5), budget(wind=4.0)
    assert drift(calm) < drift(base) < drift(windy)
    assert calm.drift_at(5.0) < base.drift_at(5.0) < windy.drift_at(5.0)
    assert base.drift_at(10.0) < windy.drift_at(10.0)


def beyond_the_edge(b) -> float:
    """The drift curve from 3 m on (% of applied, the sprayed product: a tracer), summed."""
    return sum(p["percent_of_applied"] for p in b.drift if p["distance_m"] >= 3.0)


def test_finer_drops_more_drift(base):
    fine, coarse = budget(vmd=100.0), budget(vmd=300.0)
    # the product that drifts, from 3 m on: within 1-3 m of the last row the coarse drops' wider ballistic reach spills
    # over the field's edge (why the last pass is laid inside it), and the water off the field is not the product's
    # (fine drops evaporate on the way)
    assert beyond_the_edge(coarse) < beyond_the_edge(base) < beyond_the_edge(fine)
    assert coarse.drift_at(5.0) < base.drift_at(5.0) < fine.drift_at(5.0)
    # and the fine ones evaporate more on the way
    assert coarse.fractions["evaporated"] < base.fractions["evaporated"] < fine.fractions["evaporated"]


def test_higher_flight_more_drift(base):
    high = budget(height=5.0)
    assert drift(base) < drift(high)
    assert base.drift_at(5.0) < high.drift_at(5.0)


def test_denser_canopy_more_on_the_canopy_less_on_the_ground(base):
    sparse, dense = budget(lad=2.0), budget(lad=8.0)
    on_ground = [b.fractions["ground_in_field"] + b.fractions["ground_off_field"] for b in (sparse, base, dense)]
    canopy = [b.fractions["canopy"] for b in (sparse, base, dense)]
    assert canopy[0] < canopy[1] < canopy[2]
    assert on_ground[0] > on_ground[1] > on_ground[2]
    # the hedges filter the drift too (windbreak)
    assert dense.drift_at(5.0) < sparse.drift_at(5.0)
