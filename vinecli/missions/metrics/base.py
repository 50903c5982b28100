"""The metric registry (:data:`METRICS`, :func:`metric`) and what the metric families share: windows,
the airborne samples, the mean rotor speed, smoothing, NaN for "cannot be computed"."""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.missions.rundata import EventMissing, RunData

__all__ = ["METRICS", "Metric", "Window", "airborne", "airborne_mask", "event_time_or_none", "flight_window",
           "gravity_of", "mean_rotor_speed", "metric", "nan", "reduce_or_nan", "rms", "smooth", "window_mask"]

Window = tuple[float, float] | None


@dataclass(frozen=True)
class Metric:
    fn: Callable[[RunData, Window], float]
    unit: str
    doc: str


METRICS: dict[str, Metric] = {}


def metric(name: str, unit: str) -> Callable[[Callable[[RunData, Window], float]], Callable[[RunData, Window], float]]:
    """Register a metric under ``name`` (first docstring line becomes its description)."""

    def deco(fn: Callable[[RunData, Window], float]) -> Callable[[RunData, Window], float]:
        METRICS[name] = Metric(fn, unit, (fn.__doc__ or "").strip().splitlines()[0])
        return fn

    return deco


def gravity_of(data: RunData) -> float:
    ctx = data.context
    return float(getattr(ctx, "gravity", STANDARD_GRAVITY) or STANDARD_GRAVITY)


def event_time_or_none(data: RunData, kind: str) -> float | None:
    try:
        return data.event_time(kind)
    except EventMissing:
        return None


def reduce_or_nan(fn: Callable[[np.ndarray], Any], a: np.ndarray) -> float:
    """fn(a) as a float, NaN for an empty selection."""
    return float(fn(a)) if a.size else nan()


def rms(a: np.ndarray) -> float:
    """Root mean square, NaN for an empty selection."""
    return reduce_or_nan(lambda v: np.sqrt(np.mean(v * v)), a)


def window_mask(data: RunData, window: Window, default: Window) -> np.ndarray:
    w = window if window is not None else default
    return data.window_mask(w)


def airborne_mask(columns: Mapping[str, np.ndarray]) -> np.ndarray:
    """The samples without ground contact (``on_ground`` < 0.5); all of them when the run has no ``on_ground``
    column. ``columns`` has ``t_s``."""
    if "on_ground" in columns:
        return np.asarray(columns["on_ground"], dtype=float) < 0.5
    return np.ones(np.shape(columns["t_s"]), dtype=bool)


def airborne(data: RunData) -> np.ndarray:
    return airborne_mask(data.timeseries)


def mean_rotor_speed(data: RunData) -> np.ndarray:
    cols = sorted((c for c in data.timeseries if re.fullmatch(r"rotor\d+_w_radps", c)), key=lambda c: int(c[5:-8]))
    if not cols:
        raise KeyError("rotor1_w_radps")
    return np.mean(np.vstack([data.column(c) for c in cols]), axis=0)


def smooth(y: np.ndarray, t: np.ndarray, span_s: float) -> np.ndarray:
    """Centred moving average over ``span_s`` seconds (edges use the available samples)."""
    if y.size < 3:
        return y
    dt = float(np.median(np.diff(t)))
    n = max(1, int(round(span_s / dt)))
    if n <= 1:
        return y
    k = np.ones(n)
    num = np.convolve(y, k, mode="same")
    den = np.convolve(np.ones_like(y), k, mode="same")
    return num / den


def nan() -> float:
    return float("nan")


def flight_window(data: RunData, window: Window, after_liftoff_s: float = 3.0) -> np.ndarray:
    """Samples in the air from ``after_liftoff_s`` after the lift-off to the touchdown (default window)."""
    t = data.t
    tl = event_time_or_none(data, "liftoff")
    td = event_time_or_none(data, "touchdown")
    t0 = (tl + after_liftoff_s) if tl is not None else float(t[0])
    t1 = td if (td is not None and td > t0) else float(t[-1])
    return window_mask(data, window, (t0, t1)) & airborne(data)
