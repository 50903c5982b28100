"""Time-series figures drawn in the browser: a :class:`Chart` (panels of lines on one time axis, event lines, check
windows) becomes compact JSON that ``assets/charts.js`` draws with uPlot (vendored, MIT; zoom by dragging, values
under the cursor, the panels of a figure zoom and hover together).

Compact: a column longer than :data:`FULL_SAMPLES` is reduced to the lowest and highest sample of each of
:data:`BUCKETS` equal stretches, in the order they occur (what a line of any width up to 2,000 pixels shows,
spikes included); values are 12-bit steps of the column's range (1/4095 of it: far below a pixel), stored as
differences, deflated and base64-encoded; time in ms. A figure of a 10-minute job is tens of kB. SI units.
"""

from __future__ import annotations

import base64
import json
import math
import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["BUCKETS", "FULL_SAMPLES", "Chart", "Panel", "Series", "chart_bytes", "decimate", "encode", "limits",
           "zero_aligned"]

FULL_SAMPLES = 4000  # columns up to this long travel whole
BUCKETS = 2000  # longer ones: the lowest and highest sample of each of this many stretches
LEVELS = 4095  # 12-bit steps of a column's range


@dataclass
class Series:
    """One line: its values on the chart's time axis, label, colour, width (px), dash pattern (px), drawn as steps
    (a command held until the next sample), on the right-hand axis."""

    label: str
    y: np.ndarray
    color: str
    width: float = 1.2
    dash: tuple[float, ...] = ()
    step: bool = False
    right: bool = False


@dataclass
class Panel:
    """One plot of a figure: its lines, axis labels, fixed y ranges (None: fit the data) and a line at y = 0."""

    ylabel: str
    series: list[Series]
    y2label: str = ""
    ylim: tuple[float, float] | None = None
    y2lim: tuple[float, float] | None = None
    zero: bool = False
    height: int = 220


@dataclass
class Chart:
    """A figure: panels sharing the time axis ``t`` (s), events (t s, label, colour) drawn as dotted lines, check
    windows (t0, t1, passed, label) shaded, and notes printed under it."""

    title: str
    t: np.ndarray
    panels: list[Panel]
    events: list[tuple[float, str, str]] = field(default_factory=list)
    windows: list[tuple[float, float, bool, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    xlabel: str = "time, s"


def decimate(n: int, buckets: int = BUCKETS) -> np.ndarray | None:
    """Bucket edges (start index of each stretch, and n) when ``n`` samples need reducing, else None."""
    if n <= FULL_SAMPLES:
        return None
    return np.linspace(0, n, buckets + 1).round().astype(int)


def _min_max(y: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """The lowest and highest finite sample of each stretch, in the order they occur (NaN for an empty one)."""
    starts = edges[:-1]
    k = int(np.max(np.diff(edges)))
    idx = np.minimum(starts[:, None] + np.arange(k)[None, :], y.size - 1)
    inside = np.arange(k)[None, :] < np.diff(edges)[:, None]
    v = np.where(inside, y[idx], np.nan)
    fin = np.isfinite(v)
    lo = np.where(fin, v, np.inf).argmin(axis=1)
    hi = np.where(fin, v, -np.inf).argmax(axis=1)
    first, last = np.minimum(lo, hi), np.maximum(lo, hi)
    rows = np.arange(v.shape[0])
    out = np.column_stack([v[rows, first], v[rows, last]]).ravel()
    return out


def _times(t: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Two times per stretch: its first sample's and its middle one's."""
    mid = (edges[:-1] + edges[1:] - 1) // 2
    return np.column_stack([t[edges[:-1]], t[np.maximum(mid, edges[:-1])]]).ravel()


def encode(y: np.ndarray, levels: int = LEVELS) -> dict[str, Any]:
    """``{"lo", "step", "d": base64(deflate(int16 or int32 differences of the steps)), "w": 2 | 4, "gaps"?}``: the
    value i is ``lo + step * cumsum(d)[i]``; ``gaps`` lists [start, end) index ranges without a value."""
    y = np.asarray(y, float)
    fin = np.isfinite(y)
    lo = float(y[fin].min()) if fin.any() else 0.0
    span = float(y[fin].max()) - lo if fin.any() else 0.0
    step = span / levels if span > 0 else 1.0
    q = np.zeros(y.size, np.int64)
    q[fin] = np.rint((y[fin] - lo) / step)
    if not fin.all() and fin.any():  # a gap holds the last value (small differences), and is listed
        idx = np.where(fin, np.arange(y.size), 0)
        q = q[np.maximum.accumulate(idx)]
    d = np.diff(q, prepend=0)
    wide = bool(d.size and np.abs(d).max() > 32767)
    out: dict[str, Any] = {"lo": lo, "step": step, "w": 4 if wide else 2,
                           "d": base64.b64encode(zlib.compress(d.astype("<i4" if wide else "<i2").tobytes(), 6))
                           .decode("ascii")}
    if not fin.all():
        edge = np.flatnonzero(np.diff(np.concatenate([[0], (~fin).astype(np.int8), [0]])))
        out["gaps"] = edge.reshape(-1, 2).tolist()
    return out


def limits(*arrays: np.ndarray, pad: float = 0.05, zero: bool = False) -> tuple[float, float] | None:
    """(low, high) around the finite values of ``arrays`` with ``pad`` of the span on each side (with 0 in the
    range when ``zero``); None without values."""
    vals = np.concatenate([np.asarray(a, float).ravel() for a in arrays]) if arrays else np.zeros(0)
    vals = vals[np.isfinite(vals)]
    if not vals.size:
        return None
    lo, hi = float(vals.min()), float(vals.max())
    if zero:
        lo, hi = min(lo, 0.0), max(hi, 0.0)
    p = pad * (hi - lo) if hi > lo else max(abs(hi), 1.0) * 0.05
    return lo - p, hi + p


def zero_aligned(a: tuple[float, float], b: tuple[float, float]) -> tuple[tuple[float, float], tuple[float, float]]:
    """The ranges of an axis and its twin widened so that y = 0 sits at the same height on both (signs compare)."""
    (a0, a1), (b0, b1) = a, b
    if not (a0 < 0 < a1 or b0 < 0 < b1):
        a0, b0 = min(a0, 0.0), min(b0, 0.0)
    fa = -a0 / (a1 - a0) if a1 > a0 else 0.5
    fb = -b0 / (b1 - b0) if b1 > b0 else 0.5
    f = min(max(fa, fb, 0.05), 0.95)

    def widen(lo: float, hi: float) -> tuple[float, float]:
        return (-f / (1 - f) * max(hi, 1e-12), max(hi, 1e-12)) if hi > 0 else (lo, -lo * (1 - f) / f)

    return widen(a0, a1), widen(b0, b1)


def _finite_pair(lim: tuple[float, float] | None) -> list[float] | None:
    return [float(lim[0]), float(lim[1])] if lim is not None and all(map(math.isfinite, lim)) else None


def chart_json(chart: Chart) -> dict[str, Any]:
    """The chart as the JSON ``charts.js`` draws."""
    t = np.asarray(chart.t, float)
    edges = decimate(t.size)
    x = t if edges is None else _times(t, edges)
    ms = np.rint(x * 1000.0).astype(np.int64)

    def col(y: np.ndarray) -> dict[str, Any]:
        y = np.asarray(y, float)
        return encode(y if edges is None else _min_max(y, edges))

    panels = []
    for p in chart.panels:
        panels.append({
            "ylabel": p.ylabel, "y2label": p.y2label, "ylim": _finite_pair(p.ylim), "y2lim": _finite_pair(p.y2lim),
            "zero": p.zero, "height": p.height,
            "series": [{"label": s.label, "color": s.color, "width": s.width, "dash": list(s.dash), "step": s.step,
                        "right": s.right, "y": col(s.y)} for s in p.series]})
    return {"title": chart.title, "xlabel": chart.xlabel, "n": int(t.size), "shown": int(x.size),
            "t": _encode_ms(ms), "panels": panels,
            "events": [[float(te), lab, c] for te, lab, c in chart.events],
            "windows": [[float(a), float(b), bool(ok), lab] for a, b, ok, lab in chart.windows],
            "notes": list(chart.notes)}


def _encode_ms(ms: np.ndarray) -> dict[str, Any]:
    """Times in whole ms, as int32 differences (lo 0, step 0.001 s)."""
    d = np.diff(ms, prepend=0).astype("<i4")
    return {"lo": 0.0, "step": 0.001, "w": 4, "d": base64.b64encode(zlib.compress(d.tobytes(), 6)).decode("ascii")}


def chart_bytes(chart: Chart) -> bytes:
    """:func:`chart_json` as UTF-8 JSON bytes (what the report caches and embeds)."""
    return json.dumps(chart_json(chart), separators=(",", ":"), allow_nan=False).encode()
