"""Whole-field job figures (missions/job.py and the job metrics) on synthetic time series."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vinecli.missions.job import rows_sprayed, sorties
from vinecli.missions.metrics import METRICS
from vinecli.missions.rundata import MetricContext, RunData
from vinecli.rows.detect import row_spacing_m

ROWS = [[(x, 0.0), (x, 20.0)] for x in (0.0, 1.0, 2.0, 3.0)]


def _pass_over(xs: list[float], speed: float = 2.0, dt: float = 0.05, flow: float = 0.02) -> dict[str, np.ndarray]:
    """Fly up/down the rows at ``xs`` with the flow on, one sortie per row."""
    cols: dict[str, list[float]] = {k: [] for k in ("t_s", "pos_enu_x_m", "pos_enu_y_m", "tank_flow_lps",
                                                    "power_elec_w", "sortie", "armed")}
    t = 0.0
    for i, x in enumerate(xs):
        for y in np.arange(0.0, 20.0 + 1e-9, speed * dt):
            for k, v in zip(cols, (t, x, y, flow, 600.0, i + 1.0, 1.0), strict=True):
                cols[k].append(v)
            t += dt
    return {k: np.asarray(v) for k, v in cols.items()}


def test_rows_sprayed_counts_the_rows_flown_over() -> None:
    frac, length = rows_sprayed(_pass_over([0.0, 1.0]), ROWS)
    assert frac == pytest.approx(0.5, abs=0.01)
    assert length == pytest.approx(40.0, rel=0.01)
    # 0.6 m beside a row is not over it (0.5 m radius)
    assert rows_sprayed(_pass_over([0.6]), ROWS[:1])[0] == 0.0


def test_row_spacing_is_the_median_gap_across_the_rows() -> None:
    assert row_spacing_m(ROWS) == pytest.approx(1.0)
    assert math.isnan(row_spacing_m(ROWS[:1]))


def test_sortie_table_volume_energy_and_breakpoint() -> None:
    ts = _pass_over([0.0, 1.0, 2.0])
    ev = [(10.0, "sortie", {"sortie": 1, "event": "end", "reason": "tank empty", "breakpoint_enu": [0.0, 20.0, 2.0]})]
    table = sorties(ts, ev)
    assert [s["sortie"] for s in table] == [1, 2, 3]
    per_row_s = 20.0 / 2.0 + 0.05  # 401 samples of 50 ms
    assert table[0]["volume_l"] == pytest.approx(0.02 * per_row_s, rel=0.01)
    assert table[1]["energy_wh"] == pytest.approx(600.0 * per_row_s / 3600.0, rel=0.01)
    assert table[0]["end_reason"] == "tank empty" and table[0]["breakpoint_enu"] == [0.0, 20.0, 2.0]
    assert table[2]["end_reason"] == "job done"
    assert sorties({"t_s": np.arange(3.0)}, ()) == []


def test_job_metrics_through_the_registry() -> None:
    ts = _pass_over([0.0, 1.0, 2.0, 3.0])
    data = RunData(ts, events=[(0.0, "liftoff")], context=MetricContext(rows_enu=ROWS))
    m = {k: METRICS[k].fn(data, None) for k in ("sorties", "job_time_s", "rows_sprayed_fraction",
                                                  "area_rate_ha_per_h", "litres_per_sortie")}
    assert m["sorties"] == 4 and m["rows_sprayed_fraction"] == pytest.approx(1.0)
    t_end = ts["t_s"][-1]
    assert m["job_time_s"] == pytest.approx(t_end)
    assert m["area_rate_ha_per_h"] == pytest.approx(80.0 * 1.0 / 1e4 / (t_end / 3600.0), rel=0.01)
    assert m["litres_per_sortie"] == pytest.approx(0.02 * t_end / 4, rel=0.01)
    # nothing sprayed: the spray figures are not numbers
    ts["tank_flow_lps"][:] = 0.0
    assert math.isnan(METRICS["rows_sprayed_fraction"].fn(RunData(ts, context=MetricContext(rows_enu=ROWS)), None))
