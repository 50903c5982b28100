"""The model against published multirotor spraying trials in vineyards (docs/budget.md "Compared with field
trials"): Biglia et al. 2022 (canopy deposit and ground losses, twelve configurations) and the drift bounds
of Herbst et al. 2023 and Bonds et al. 2024 (their abstracts) against the basic drift values of
Rautmann et al. 2001. The bands asserted here are the agreement docs/budget.md states, number by number;
benchmarks/published_trials.py prints the table.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vinecli.spray.budget import BudgetConfig
from vinecli.spray.published_trials import BIGLIA_2022, CONFIGS, RAUTMANN_2001, drift_trial, reading
from vinecli.spray.spray_trial import run_trial


@pytest.fixture(scope="module")
def readings() -> dict[str, dict[str, float]]:
    return {c.name: reading(c) for c in CONFIGS}


def mean(readings, names, key):
    return float(np.mean([readings[n][key] for n in names]))


BAND, BAND_CONV = ["T9", "T10", "T11", "T12"], ["T9", "T10"]
ONE_WAY, TWO_WAY = ["T1", "T2", "T3", "T4"], ["T5", "T6", "T7", "T8"]


def test_biglia_band_spraying_within_a_factor_of_1_5(readings):
    # the wake carries the band spray down as a plume about a metre wide (spray/wake.py), so a pass along the
    # hedge puts most of it into the canopy: canopy deposits within a factor 1.5 of the paper (docs/budget.md)
    for names, key in ((BAND_CONV, "canopy_band_conventional"), (BAND, "canopy_band")):
        ratio = mean(readings, names, "canopy") / BIGLIA_2022[key]
        assert 1 / 1.5 <= ratio <= 1.5, (key, ratio)


def test_biglia_broadcast_ground_losses_agree(readings):
    # broadcast (across the rows, 1-way and 2-way: both apply the same dose per cm of the line): within 25 %
    assert mean(readings, ONE_WAY, "ground") == pytest.approx(BIGLIA_2022["ground_broadcast_1way"], rel=0.25)
    assert mean(readings, TWO_WAY, "ground") == pytest.approx(BIGLIA_2022["ground_broadcast_2way"], rel=0.25)


def test_biglia_band_spraying_puts_more_on_the_canopy_than_broadcast(readings):
    band, broad = mean(readings, BAND, "canopy"), mean(readings, ONE_WAY + TWO_WAY, "canopy")
    assert band > 1.5 * broad  # the paper: +209 % (0.161 vs 0.052); the model: ~+90 %, the same way
    # and the canopy's top catches more than its bottom, three times more in the paper (Fig. 11)
    for n in BAND:
        assert readings[n]["canopy_top"] > 2.0 * readings[n]["canopy_bottom"]
    # the budget of a band pass at 1 m/s in light wind with conventional drops (T9): 25-60 % of the spray on the
    # canopy (the bound). The air-inclusion hollow cone (T11) lands its coarse drops on a 1.6 m ring, beyond the 0.55 m
    # hedge, so less: the paper's air-inclusion band deposit is (4 x 0.161 - 2 x 0.237) / 2 = 0.085 µL/cm², 0.36x
    # the conventional 0.237; the model's T11 share is ~0.6x T9's (0.23 against 0.37), above the paper's ratio
    assert 0.25 <= readings["T9"]["fraction_canopy"] <= 0.60
    assert 0.36 * readings["T9"]["fraction_canopy"] < readings["T11"]["fraction_canopy"] < readings["T9"]["fraction_canopy"]


def test_biglia_where_the_model_still_disagrees(readings):
    # stated in docs/budget.md: band-mode ground losses ~1.5x the paper's, carried by the air-inclusion passes (their
    # hollow cones' coarse drops land on a 1.6 m ring: the dishes at 1.25 m catch its inner edge, where the paper
    # found much less than at 0.625 m), while the conventional band passes agree; broadcast canopy 1.2-1.7x
    assert 1.3 < mean(readings, BAND, "ground") / BIGLIA_2022["ground_band"] < 2.2
    assert mean(readings, ["T9", "T10"], "ground") / BIGLIA_2022["ground_band"] < 1.5
    assert mean(readings, ["T11", "T12"], "ground") > 1.5 * mean(readings, ["T9", "T10"], "ground")
    assert 1.2 < mean(readings, ONE_WAY + TWO_WAY, "canopy") / BIGLIA_2022["canopy_broadcast"] < 1.7


def edge_pass(vmd: float, wind: float, seed: int = 0):
    """One pass along the downwind edge row of a full-leaf vineyard (ten rows 2.5 m apart, 62 m) by an M600-class
    hexacopter 3 m above the ground at 3 m/s, hollow cones of the given VMD, in a crosswind blowing off the field."""
    base = drift_trial(True, wind, seed)
    veh = dataclasses.replace(base.vehicle, vmd_um=vmd)
    x = base.rows[-1][0][0]
    distances = BudgetConfig(drift_distances_m=(1.0, 3.0, 5.0, 7.5, 10.0, 15.0, 20.0, 30.0, 50.0))
    return run_trial(dataclasses.replace(base, vehicle=veh, passes=[((x, -5.0), (x, 67.0))], budget=distances))[0]


@pytest.mark.parametrize("vmd", [150.0, 200.0])
def test_edge_row_drift_curve_in_a_2_mps_crosswind(vmd):
    b = edge_pass(vmd, 2.0)
    assert b.balance_error <= 1e-9
    curve = {p["distance_m"]: p["percent_of_applied"] for p in b.drift}
    assert 0.02 <= curve[5.0] <= 5.0 and 0.02 <= curve[7.5] <= 5.0
    assert curve[20.0] < 0.5
    assert curve[50.0] > 0.0
    far = [curve[d] for d in (5.0, 7.5, 10.0, 15.0, 20.0, 30.0, 50.0)]
    assert all(a > b for a, b in zip(far[:-1], far[1:], strict=True)), far
    # the share that left the field (sedimenting + airborne out of the domain) and the airborne share are the
    # surface layer's: both positive
    assert b.fractions["ground_off_field"] > 0.0


def test_edge_row_far_tail_decays_like_the_basic_drift_values():
    # the far tail (docs/budget.md): fine drops the canopy's eddies lift out of the crop (spray/outwash.py) reach 50 m;
    # trials report a few hundredths of a percent there, and the basic drift values for vines (Rautmann et al. 2001,
    # the JKI table to 50 m: late 1.23 % at 10 m, 0.10 % at 50 m; early 0.39, 0.03) fall by a factor 12-13 from 10 to
    # 50 m: the model's edge pass (150 µm, 2 m/s) within 2.5x of that decay, and at least 0.005 % at 50 m
    b = edge_pass(150.0, 2.0)
    assert b.balance_error <= 1e-9
    curve = {p["distance_m"]: p["percent_of_applied"] for p in b.drift}
    assert curve[50.0] >= 0.005
    assert curve[10.0] / curve[50.0] <= 2.5 * 12.3


@pytest.fixture(scope="module")
def drift_curves() -> dict[bool, dict[float, float]]:
    out = {}
    for conventional in (True, False):
        b, _ = run_trial(drift_trial(conventional))
        assert b.balance_error <= 1e-9
        out[conventional] = {p["distance_m"]: p["percent_of_applied"] for p in b.drift}
    return out


def test_drift_air_inclusion_below_the_vineyard_basic_drift_values(drift_curves):
    # Herbst et al. 2023: with air-induction nozzles the drones' 90th-percentile drift sediment is below the
    # basic drift values of ground sprayers in vineyards (3-20 m; the abstract does not say early or late vines):
    # below the late values everywhere, below the lower, early ones from 5 m on (3 m: 3.1 % against 2.70 %,
    # docs/budget.md says so)
    for d, late in RAUTMANN_2001["vines, late"].items():
        assert drift_curves[False][d] < late
        assert drift_curves[False][d] < RAUTMANN_2001["vines, early"][d] or d < 5.0
        assert drift_curves[False][d] <= drift_curves[True][d]


def test_drift_conventional_above_the_boom_and_its_tail_reaches_50_m(drift_curves):
    # Bonds et al. 2024 and Agroscope: UASS drift is higher than ground booms'; Sanchez-Fernandez et al. 2025: in vines
    # above the ground sprayers' reference (fine drops from 3 m, the whole field sprayed in a 3 m/s crosswind)
    for d in (3.0, 5.0, 10.0, 15.0, 20.0):
        assert drift_curves[True][d] > RAUTMANN_2001["arable"][d]
    assert drift_curves[True][50.0] > 0.0
