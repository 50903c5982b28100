"""Canopy and air specs of a world (``canopy:``, ``air:`` in worlds/*.yaml); docs/budget.md.

``canopy`` describes every row's hedge (:mod:`vinecli.spray.canopy`): a growth stage (BBCH) gives
the defaults, any dimension given overrides them, ``source: chm`` measures each row's height on the
world's surface model (the canopy height model of its DSM), ``rows`` overrides single rows.
``air`` gives the temperature and humidity that evaporate drops in flight.
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, model_validator

from vinecli.specs import StrictModel

__all__ = ["AirSpec", "CanopySpec", "RowCanopySpec"]


class RowCanopySpec(StrictModel):
    """One row's own canopy values (row index in the world's rows, 0-based); unset fields keep the world's."""

    row: int = Field(ge=0)
    base_m: float | None = Field(None, ge=0, le=20)
    top_m: float | None = Field(None, ge=0, le=40)
    width_m: float | None = Field(None, ge=0, le=10)
    lad_m2m3: float | None = Field(None, ge=0, le=50)


class CanopySpec(StrictModel):
    """Hedges along the rows: growth stage defaults, dimensions, leaf area density and its vertical profile."""

    bbch: int = Field(75, ge=0, le=99, description="growth stage (BBCH), sets the defaults of the other fields")
    source: Literal["bbch", "chm"] = Field(
        "bbch", description="bbch: heights from the stage (or given); chm: each row's height measured on the "
        "world's surface model (canopy top minus the ground in the inter-rows)")
    base_m: float | None = Field(None, ge=0, le=20, description="bottom of the foliage above the ground, m")
    top_m: float | None = Field(None, ge=0, le=40, description="top of the foliage above the ground, m")
    width_m: float | None = Field(None, ge=0, le=10, description="hedge width across the row, m")
    lad_m2m3: float | None = Field(None, ge=0, le=50, description="mean leaf area density, m²/m³")
    profile: list[float] = Field(default_factory=lambda: [1.0], min_length=1, max_length=100,
                                 description="relative LAD of equal-height layers from the base up (mean 1)")
    g_factor: float = Field(0.5, gt=0, le=1, description="mean leaf projection on the drops' path (0.5: spherical)")
    leaf_width_m: float = Field(0.12, gt=0, le=2, description="characteristic leaf width for impaction, m")
    rows: list[RowCanopySpec] = Field(default_factory=list, description="per-row overrides")
    segment_m: float = Field(2.0, ge=1, le=5, description="length of the canopy segments measured along each row, m "
                             "(docs/dose.md)")
    gap_min_m: float = Field(0.5, ge=0.1, le=20, description="an absence of canopy at least this long is a gap "
                             "(missing vines), m")

    @model_validator(mode="after")
    def _check(self) -> CanopySpec:
        if any(v < 0 for v in self.profile) or sum(self.profile) <= 0:
            raise ValueError("profile: values must be >= 0 and not all 0")
        if self.base_m is not None and self.top_m is not None and self.top_m < self.base_m:
            raise ValueError("top_m must be >= base_m")
        return self


class AirSpec(StrictModel):
    """Air temperature and relative humidity (drop evaporation in flight), and the surface layer's stability (the
    far-field drift, docs/budget.md)."""

    temperature_c: float = Field(ge=-20, le=50, description="air temperature, °C")
    relative_humidity_pct: float = Field(ge=5, le=100, description="relative humidity, %")
    obukhov_length_m: float | None = Field(
        None, description="Obukhov length of the surface layer, m: > 0 stable (night, calm: tens of m), < 0 unstable "
                          "(sunny afternoon: -10 to -100 m); none: neutral")

    @model_validator(mode="after")
    def _nonzero_length(self) -> AirSpec:
        if self.obukhov_length_m is not None and (self.obukhov_length_m == 0 or not math.isfinite(self.obukhov_length_m)):
            raise ValueError("obukhov_length_m: give a finite length other than 0 (or none for neutral air)")
        return self
