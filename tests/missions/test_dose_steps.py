"""The as-applied judgement of rate steps and gaps (vinecli.missions.as_applied, dose_steps) on a pass flown by the
real pump model: a vehicle at constant speed along a straight row, the sprayer commanding each piece's litres per
metre led by the pump's lag as the built-in autopilot does (a rise speed x tau_up ahead, a fall speed x tau_down
ahead), the first-order pump (vinecli.flight.pump.Pump) delivering it. Every transition distance lies within its
bound from pump lag x speed, and the bound is the first-order law's; a pump three times slower than the sprayer
assumes overruns it (the check can fail); the gap is not sprayed beyond the pump's run-down."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vinecli.flight.pump import Pump
from vinecli.missions.as_applied import DoseRun, as_applied, rate_zones
from vinecli.missions.dose_steps import POSITION_MARGIN_M, step_bound_m
from vinecli.rows.segment_rates import RateSegment, SegmentRates
from vinecli.specs.sprayer import PumpSpec

ROW = [(0.0, 0.0), (0.0, 40.0)]
#: (s0, s1, L/ha): a rise, a fall to a gap, a rise out of it, a small step (< 10 %: not judged), a fall
PIECES = ((0.0, 10.0, 20.0), (10.0, 20.0, 40.0), (20.0, 25.0, 0.0), (25.0, 32.0, 10.0), (32.0, 36.0, 10.5),
          (36.0, 40.0, 6.0))
WIDTH, SPACING, SPEED, TAU_UP, TAU_DOWN = 2.5, 2.5, 2.0, 0.3, 0.15
DT, RECORD = 0.004, 5  # 250 Hz physics, 50 Hz records


def _rates() -> SegmentRates:
    segs = tuple(RateSegment(0, a, b, (0.0, a), (0.0, b), r, r == 0.0, 1.0, 0.5, 1.0 if r else 0.0, 0.0, 0.0)
                 for a, b, r in PIECES)
    return SegmentRates(segs, SPACING, None, None, 40.0, "rows")


def _rate_at(s: float) -> float:
    return next((r for a, b, r in PIECES if a <= s < b), PIECES[-1][2] if s >= PIECES[-1][1] else PIECES[0][2])


def _fly(pump_tau_scale: float = 1.0) -> dict[str, np.ndarray]:
    """A pass from y = -3 m to 43 m at SPEED; the command led by the nominal lags, the pump ``pump_tau_scale``
    times slower."""
    pump = Pump(PumpSpec(tau_up_s=TAU_UP * pump_tau_scale, tau_down_s=TAU_DOWN * pump_tau_scale), 1.0)
    per_lpha = WIDTH / 1e4
    cols: dict[str, list[float]] = {k: [] for k in ("t_s", "pos_enu_x_m", "pos_enu_y_m", "vel_enu_x_mps",
                                                    "vel_enu_y_mps", "tank_flow_lps", "phase_index")}
    n = int(46.0 / SPEED / DT)
    for k in range(n):
        y = -3.0 + SPEED * k * DT
        up = _rate_at(y + SPEED * TAU_UP) if 0.0 <= y + SPEED * TAU_UP <= 40.0 else 0.0
        dn = _rate_at(y + SPEED * TAU_DOWN) if 0.0 <= y + SPEED * TAU_DOWN <= 40.0 else 0.0
        q = pump.update(max(up, dn) * per_lpha * SPEED, DT)
        if k % RECORD == 0:
            for key, v in (("t_s", k * DT), ("pos_enu_x_m", 0.0), ("pos_enu_y_m", y), ("vel_enu_x_mps", 0.0),
                           ("vel_enu_y_mps", SPEED), ("tank_flow_lps", q), ("phase_index", 1)):
                cols[key].append(v)
    return {k: np.asarray(v) for k, v in cols.items()}


def _run() -> DoseRun:
    return DoseRun(1, [ROW], WIDTH, {0: (0.0, 40.0)}, SPEED, TAU_UP, TAU_DOWN, record_rate_hz=1.0 / (DT * RECORD),
                   position_margin_m=POSITION_MARGIN_M)


def test_every_step_within_its_pump_lag_bound_and_the_gap_stays_dry() -> None:
    aa = as_applied(_fly(), _rates(), _run())
    steps = {(round(s.old_lpha, 1), round(s.new_lpha, 1)): s for s in aa.steps}
    assert set(steps) == {(20.0, 40.0), (40.0, 0.0), (0.0, 10.0), (10.5, 6.0)}  # 10 -> 10.5 is within 10 %
    for s in steps.values():
        assert s.reached and s.within_bound, s
    # the bound is the first-order law: 20 -> 40 L/ha settles within 10 % tau_up (ln(20 / 4) - 1) after the boundary
    rise = steps[(20.0, 40.0)]
    law = SPEED * TAU_UP * (math.log(20.0 / 4.0) - 1.0)
    assert rise.bound_m == pytest.approx(law + 0.1 + SPEED * DT * RECORD + POSITION_MARGIN_M, abs=1e-3)
    assert rise.distance_m == pytest.approx(law, abs=0.1 + SPEED * DT * RECORD)  # measured on the real pump
    gap = aa.gaps[0]
    assert gap["judged"] and not gap["sprayed"] and gap["interior_max_ratio"] < 0.1
    assert aa.metrics["dose_gaps_sprayed"] == 0 and aa.metrics["dose_transitions_over_bound"] == 0
    # away from the steps the pump delivers the prescription; a lag led by its own time constant moves no volume
    b = aa.bins[0]
    steady = np.ones(b["s_m"].size, bool)
    for a in [*(a for a, _, _ in PIECES), PIECES[-1][1]]:  # the boundaries, the pass's ends
        steady &= np.abs(b["s_m"] - a) > 2.0
    sprayed = steady & (b["prescribed"] > 0)
    assert np.allclose(b["pump"][sprayed], b["prescribed"][sprayed], rtol=0.02)
    assert aa.product["applied_l"] == pytest.approx(aa.product["prescribed_l"], rel=0.03)


def test_a_pump_slower_than_the_sprayer_assumes_overruns_the_bound() -> None:
    aa = as_applied(_fly(pump_tau_scale=3.0), _rates(), _run())
    assert aa.metrics["dose_transitions_over_bound"] >= 2
    assert any(g["sprayed"] for g in aa.gaps)  # its run-down reaches into the gap


def test_bound_formula() -> None:
    assert step_bound_m(20.0, 40.0, 2.0, 0.3, 0.15, 0.1, 0.0) == pytest.approx(0.6 * (math.log(5.0) - 1.0))
    assert step_bound_m(40.0, 20.0, 2.0, 0.3, 0.15, 0.1, 0.0) == pytest.approx(0.3 * (math.log(10.0) - 1.0))
    assert step_bound_m(40.0, 0.0, 2.0, 0.3, 0.15, 0.1, 0.25) == pytest.approx(0.3 * (math.log(10.0) - 1.0) + 0.25)
    assert step_bound_m(20.0, 21.0, 2.0, 0.3, 0.15, 0.1, 0.0) == 0.0  # within 10 % at once
    # a speed estimate off by 0.05 m/s at 2 m/s leaves 7.5 % of the band to settle into
    assert step_bound_m(20.0, 40.0, 2.0, 0.3, 0.15, 0.1, 0.0, 0.05) == pytest.approx(0.6 * (math.log(20 / 3) - 1.0))


def test_rate_zones() -> None:
    k, names = rate_zones([14.0, 22.0, 30.0, 22.0])
    assert names == ["14 L/ha", "22 L/ha", "30 L/ha"] and k.tolist() == [0, 1, 2, 1]
    k, names = rate_zones(np.linspace(10.0, 20.0, 40))
    assert len(names) == 5 and k.min() == 0 and k.max() == 4
