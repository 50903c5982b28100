"""Defaults of ``vinecli vehicle fit`` / ``replay`` (a light module: the CLI reads it for its help)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["FIT_DEFAULTS"]


@dataclass(frozen=True)
class FitDefaults:
    base: str = "x500"  # the vehicle the unidentified parameters come from
    window_s: float = 2.0  # replay: length of each open-loop window, s


FIT_DEFAULTS = FitDefaults()
