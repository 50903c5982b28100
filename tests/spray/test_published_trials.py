"""The model against published multirotor spraying trials in vineyards (docs/budget.md "Compared with field
trials"): Biglia et al. 2022 (canopy deposit and ground losses, twelve configurations) and the drift bounds
of Herbst et al. 2023 and Bonds et al. 2024 (their abstracts) against the basic drift values of
Rautmann et al. 2001. The bands asserted here are the agreement docs/budget.md states, number by number;
benchmarks/published_trials.py prints the table.
"""

from __future__ import annotations

import numpy as np
import pytest

from vinecli.spray.published_trials import BIGLIA_2022, CONFIGS, RAUTMANN_2001, drift_trial, reading
from vinecli.spray.spray_trial import run_trial


@pytest.fixture(scope="module")
def readings() -> dict[str, dict[str, float]]:
    return {c.name: reading(c) for c in CONFIGS}


def mean(readings, names, key):
    return float(np.mean([readings[n][key] for n in names]))


BAND, BAND_CONV = ["T9", "T10", "T11", "T12"], ["T9", "T10"]
ONE_WAY, TWO_WAY = ["T1", "T2", "T3", "T4"], ["T5", "T6", "T7", "T8"]


def test_biglia_broadcast_canopy_and_two_way_ground_agree(readings):
    # broadcast (across the rows): canopy deposit and the 2-way ground losses within 25 % of the paper
    assert mean(readings, ONE_WAY + TWO_WAY, "canopy") == pytest.approx(BIGLIA_2022["canopy_broadcast"], rel=0.25)
    assert mean(readings, TWO_WAY, "ground") == pytest.approx(BIGLIA_2022["ground_broadcast_2way"], rel=0.25)


def test_biglia_band_spraying_puts_more_on_the_canopy_than_broadcast(readings):
    band, broad = mean(readings, BAND, "canopy"), mean(readings, ONE_WAY + TWO_WAY, "canopy")
    assert band > 1.3 * broad  # the paper: +209 % (0.161 vs 0.052); the model: +60 %, the same way
    # and the canopy's top catches more than its bottom, three times more in the paper (Fig. 11)
    for n in BAND:
        assert readings[n]["canopy_top"] > 2.0 * readings[n]["canopy_bottom"]


def test_biglia_band_mode_is_where_the_model_disagrees(readings):
    # the model's spray footprint is the geometric cone (docs/deposition.md): flown over one 0.55 m hedge the
    # band spray lands mostly beside it; the paper measured the downwash conveying it into the canopy. The
    # disagreement stated in docs/budget.md: canopy 0.2-0.5x, ground 1.5-3x the paper's
    assert 0.2 < mean(readings, BAND_CONV, "canopy") / BIGLIA_2022["canopy_band_conventional"] < 0.5
    assert 1.5 < mean(readings, BAND, "ground") / BIGLIA_2022["ground_band"] < 3.0
    assert 0.35 < mean(readings, ONE_WAY, "ground") / BIGLIA_2022["ground_broadcast_1way"] < 0.8


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
    # basic drift values of ground sprayers in vineyards
    for d, ref in RAUTMANN_2001["vines, late"].items():
        assert drift_curves[False][d] < ref
        assert drift_curves[False][d] <= drift_curves[True][d]


def test_drift_conventional_between_ground_boom_and_orchard_airblast_near_the_field(drift_curves):
    # Bonds et al. 2024: UASS drift is higher than ground booms' and lower than aerial, similar to orchard air-blast.
    # The model: above the boom's and below the orchard air-blast's up to 10 m; beyond, its tail falls below the
    # boom's (docs/budget.md: no far-field airborne transport above the outwash)
    for d in (3.0, 5.0, 10.0):
        assert RAUTMANN_2001["arable"][d] < drift_curves[True][d] < RAUTMANN_2001["fruit, late"][d]
    assert drift_curves[True][20.0] < RAUTMANN_2001["arable"][20.0]
