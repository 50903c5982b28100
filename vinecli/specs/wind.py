"""Wind laws as data (world and mission files). World frame ENU, m/s.

A law is one of the models below or a ``sum`` of them; the physics module
:mod:`vinecli.flight.wind` turns a spec into a callable field ``velocity(t, p_enu)``.
Headings are compass degrees the wind blows TOWARDS, measured from north clockwise
(0 = towards north, 90 = towards east).
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field

from vinecli.specs import StrictModel
from vinecli.specs.limits import MAX_DISTANCE_M, MAX_DURATION_S, MAX_SPEED_MPS, SeedInt, Speed, Vec3Speed

#: relative change of wind speed per metre (±1 = doubles or vanishes within a metre)
Gradient = Annotated[float, Field(ge=-1.0, le=1.0)]



class ConstantWind(StrictModel):
    type: Literal["constant"] = "constant"
    velocity_enu: Vec3Speed = Field((0.0, 0.0, 0.0), description="m/s, world ENU")


class SinusoidWind(StrictModel):
    """Thesis §5.3: W(t) = mean + amplitude sin(2π t / period + phase) along a horizontal heading."""

    type: Literal["sinusoid"] = "sinusoid"
    mean_mps: Speed = 0.0
    amplitude_mps: Speed = 0.0
    period_s: float = Field(10.0, gt=0, le=MAX_DURATION_S)
    phase_rad: float = Field(0.0, ge=-1e3, le=1e3)
    heading_deg: float = Field(90.0, description="direction the wind blows towards, deg from north, clockwise")
    start_s: float = Field(0.0, ge=0, le=MAX_DURATION_S, description="law is zero before this time")


class GustWind(StrictModel):
    """Discrete 1-cosine gust: V(t) = peak/2 (1 - cos(2π (t - start)/duration)) for t in the gust."""

    type: Literal["gust"] = "gust"
    peak_mps: Speed
    start_s: float = Field(ge=0, le=MAX_DURATION_S)
    duration_s: float = Field(gt=0, le=MAX_DURATION_S)
    heading_deg: float = 90.0
    vertical_mps: Speed = Field(0.0, description="peak vertical component (up positive)")


class DrydenWind(StrictModel):
    """Dryden turbulence (MIL-F-8785C, low altitude), seeded, added to a mean wind."""

    type: Literal["dryden"] = "dryden"
    mean_mps: float = Field(0.0, ge=0, le=MAX_SPEED_MPS, description="mean wind at 6 m (20 ft), m/s")
    heading_deg: float = 90.0
    intensity: Literal["light", "moderate", "severe"] | None = None
    sigma_mps: float | None = Field(None, ge=0, le=MAX_SPEED_MPS, description="overrides intensity: horizontal σ, m/s")
    airspeed_mps: float = Field(5.0, gt=0, le=MAX_SPEED_MPS, description="reference airspeed for the spatial-to-temporal frequency, m/s")
    altitude_m: float = Field(5.0, gt=0, le=MAX_DISTANCE_M, description="height above ground used for scale lengths, m")
    seed_offset: SeedInt = Field(0, description="added to the run seed")


class SpatialShear(StrictModel):
    """Optional spatial variation: power-law shear with height and a linear horizontal gradient."""

    reference_height_m: float = Field(6.0, gt=0, le=MAX_DISTANCE_M)
    shear_exponent: float = Field(0.0, ge=0, le=1.0, description="V(h) = V_ref (h/h_ref)^alpha (0 = uniform)")
    gradient_per_m: tuple[Gradient, Gradient, Gradient] = Field((0.0, 0.0, 0.0), description="relative change of speed per metre east, north, up")


class SumWind(StrictModel):
    type: Literal["sum"] = "sum"
    terms: list[WindLaw] = Field(min_length=1)


WindLaw = Annotated[
    ConstantWind | SinusoidWind | GustWind | DrydenWind | SumWind,
    Field(discriminator="type"),
]
SumWind.model_rebuild()


class WindSpec(StrictModel):
    """A wind law plus optional spatial variation."""

    law: WindLaw = ConstantWind()
    spatial: SpatialShear | None = None

    def mean_horizontal_enu(self) -> tuple[float, float]:
        """The law's mean horizontal wind (m/s, east, north): the constant, the sinusoid's and Dryden's means along
        their heading, sums added; a discrete gust has none."""
        return _mean_xy(self.law)


def _mean_xy(law: object) -> tuple[float, float]:
    if isinstance(law, ConstantWind):
        return float(law.velocity_enu[0]), float(law.velocity_enu[1])
    if isinstance(law, (SinusoidWind, DrydenWind)):
        h = math.radians(law.heading_deg)
        return law.mean_mps * math.sin(h), law.mean_mps * math.cos(h)
    if isinstance(law, SumWind):
        parts = [_mean_xy(t) for t in law.terms]
        return sum(p[0] for p in parts), sum(p[1] for p in parts)
    return 0.0, 0.0
