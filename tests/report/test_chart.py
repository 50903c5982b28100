"""The browser-drawn time-series figures' data (vinecli/report/chart.py): a column comes back within half a 12-bit
step of its range; a long one keeps each stretch's lowest and highest sample (a one-sample spike survives), in
order; gaps stay gaps; time comes back to the millisecond; twin axes share their zero."""

from __future__ import annotations

import base64
import json
import zlib
from typing import Any

import numpy as np
import pytest

from vinecli.report.chart import BUCKETS, FULL_SAMPLES, Chart, Panel, Series, chart_bytes, encode, zero_aligned


def decode(enc: dict[str, Any]) -> np.ndarray:
    """What charts.js computes from an encoded column (None -> NaN)."""
    d = np.frombuffer(zlib.decompress(base64.b64decode(enc["d"])), "<i4" if enc["w"] == 4 else "<i2")
    out = enc["lo"] + enc["step"] * np.cumsum(d.astype(np.int64))
    for a, b in enc.get("gaps", []):
        out[a:b] = np.nan
    return out


def decode_chart(chart: dict[str, Any]) -> tuple[np.ndarray, list[list[np.ndarray]]]:
    """(time s, [[each series' values] per panel]) of a chart's JSON."""
    return decode(chart["t"]), [[decode(s["y"]) for s in p["series"]] for p in chart["panels"]]


def test_a_column_comes_back_within_half_a_step() -> None:
    rng = np.random.default_rng(3)
    y = np.cumsum(rng.normal(0, 1, 3000))
    y[100:140] = np.nan
    enc = encode(y)
    back = decode(enc)
    step = (np.nanmax(y) - np.nanmin(y)) / 4095
    fin = np.isfinite(y)
    assert np.max(np.abs(back[fin] - y[fin])) <= 0.5 * step + 1e-9
    assert np.isnan(back[100:140]).all() and enc["gaps"] == [[100, 140]]
    assert np.allclose(decode(encode(np.full(10, 7.25))), 7.25)  # a constant


def test_a_long_column_keeps_every_stretchs_extremes_and_time() -> None:
    n = 3 * FULL_SAMPLES
    t = np.arange(n) * 0.004 + 1.0
    y = np.sin(t)
    y[5001] = 40.0  # a one-sample spike
    y[9000] = -40.0
    chart = json.loads(chart_bytes(Chart("x", t, [Panel("y", [Series("y", y, "#000")])])))
    tt, ((back,),) = decode_chart(chart)
    assert chart["n"] == n and chart["shown"] == back.size == tt.size == 2 * BUCKETS
    assert back.max() == pytest.approx(40.0, abs=0.02) and back.min() == pytest.approx(-40.0, abs=0.02)
    assert np.all(np.diff(tt) >= 0) and tt[0] == pytest.approx(1.0) and tt[-1] <= t[-1]
    # each stretch's pair is its lowest and highest sample in the order they occur
    edges = np.linspace(0, n, BUCKETS + 1).round().astype(int)
    k = int(np.searchsorted(edges, 5001, side="right")) - 1
    lo, hi = y[edges[k]:edges[k + 1]].min(), 40.0
    assert sorted(back[2 * k:2 * k + 2]) == pytest.approx([lo, hi], abs=0.02)


def test_short_columns_travel_whole() -> None:
    t = np.linspace(0.0, 10.0, 501)
    chart = json.loads(chart_bytes(Chart("x", t, [Panel("y", [Series("y", t ** 2, "#000", step=True)])])))
    tt, ((back,),) = decode_chart(chart)
    assert np.allclose(tt, t, atol=5e-4) and np.allclose(back, t ** 2, atol=100 / 4095)
    assert chart["panels"][0]["series"][0]["step"] is True


@pytest.mark.parametrize(("a", "b"), [((-1.0, 3.0), (0.0, 10.0)), ((-5.0, 1.0), (-0.2, 4.0)), ((2.0, 4.0), (1.0, 3.0))])
def test_twin_axes_share_their_zero(a: tuple[float, float], b: tuple[float, float]) -> None:
    (a0, a1), (b0, b1) = zero_aligned(a, b)
    assert a0 <= min(a[0], 0.0) + 1e-12 and a1 >= a[1] - 1e-12 and b0 <= min(b[0], 0.0) + 1e-12 and b1 >= b[1] - 1e-12
    assert -a0 / (a1 - a0) == pytest.approx(-b0 / (b1 - b0))
