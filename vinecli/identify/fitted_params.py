"""A fitted parameter with its uncertainty and provenance, and the block bootstrap every fit uses.

Residuals of a flight log are correlated in time (a gust, a manoeuvre, the battery's sag last seconds),
so the standard deviations come from a moving-block bootstrap (Künsch 1989): the regression is refitted
on resamples made of contiguous blocks of samples (default 2 s), and the std is that of the refits.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Param", "block_bootstrap", "fixed"]

#: a parameter counts as identified when its bootstrap std is below this fraction of its value
IDENTIFIED_REL_STD = 0.5
#: resamples of the block bootstrap (deterministic seed)
BOOTSTRAP_RESAMPLES = 200


@dataclass(frozen=True)
class Param:
    """One parameter: value, unit, standard deviation (NaN: not estimated), where it came from."""

    value: float
    unit: str
    std: float = math.nan
    source: str = "fit"  # "fit" | "log" (a firmware parameter) | "base" (fixed from --base) | "derived"
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        """``{value, unit, std, source, note}`` (NaN std as null)."""
        return {"value": self.value, "unit": self.unit, "std": None if math.isnan(self.std) else self.std,
                "source": self.source, "note": self.note}

    @property
    def identified(self) -> bool:
        """Fitted with a std below :data:`IDENTIFIED_REL_STD` of its value."""
        return self.source == "fit" and math.isfinite(self.std) and self.std < IDENTIFIED_REL_STD * abs(self.value)


def fixed(value: float, unit: str, why: str, source: str = "base") -> Param:
    """A parameter the log cannot identify, taken from ``source`` (std not estimated)."""
    return Param(float(value), unit, math.nan, source, why)


def block_bootstrap(t: np.ndarray, fit: Callable[[np.ndarray], np.ndarray], *, block_s: float = 2.0,
                    resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0) -> np.ndarray:
    """Std of ``fit(indices)`` (a 1-D array of parameters) over moving-block resamples of the samples at
    times ``t`` (s, sorted). ``fit`` gets an index array into the samples (with repeats) and returns its
    parameters; resamples where it raises ValueError or returns non-finite values are skipped."""
    n = len(t)
    rng = np.random.default_rng(seed)
    dt = float(np.median(np.diff(t))) if n > 1 else 1.0
    block = max(1, min(n, int(round(block_s / max(dt, 1e-9)))))
    starts_max = n - block + 1
    per = int(math.ceil(n / block))
    out = []
    for _ in range(resamples):
        starts = rng.integers(0, starts_max, per)
        idx = (starts[:, None] + np.arange(block)[None, :]).ravel()[:n]
        try:
            p = np.asarray(fit(idx), dtype=float)
        except (ValueError, np.linalg.LinAlgError):
            continue
        if np.all(np.isfinite(p)):
            out.append(p)
    if len(out) < max(10, resamples // 4):
        return np.full(len(np.asarray(fit(np.arange(n)))), np.nan)
    return np.std(np.array(out), axis=0, ddof=1)
