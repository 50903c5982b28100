"""Dose expressions of three-dimensional crops and their conversion to an application rate (docs/dose.md).

Units: lengths m, leaf wall area (LWA) m² per ha of ground, tree-row volume (TRV) m³ per ha of ground, the
application rate L of spray liquid per ha of ground (vinecli's ``rate_lpha``), label doses in litres of spray
liquid per 10 000 m² of LWA or per 10 000 m³ of TRV.

* Leaf wall area (EPPO PP 1/239(3) 2021, the dose expression of the EU Central Zone for vines and pome fruit,
  efficacy trials since 2018, dossiers since 2020): ``LWA = 10 000 / row spacing x leaf-wall height x sides
  treated``: the area of the hedges' faces the sprayer treats on one hectare of ground. 2.5 m rows with a
  1.2 m leaf wall treated from both sides: 10 000 / 2.5 x 1.2 x 2 = 9 600 m²/ha.
* Tree-row volume (Byers et al. 1971; converted by PACE, Walklate et al.): ``TRV = leaf-wall height x canopy
  width x 10 000 / row spacing``: the hedges' volume on one hectare. 2.5 m rows, 1.2 m high, 0.5 m wide:
  2 400 m³/ha.
* A label dose per 10 000 m² of LWA applies ``rate = dose x LWA / 10 000`` per ha of ground (PP 1/239(3),
  the conversion between the LWA and ground-area expressions); per 10 000 m³ of TRV likewise
  ``rate = dose x TRV / 10 000``. 200 L per 10 000 m² LWA on the 9 600 m²/ha above: 192 L/ha.

The leaf-wall height is the foliage's (top minus foliage base), not the vine's: a canopy of a segment
(:mod:`vinecli.rows.canopy_segments`) gives it, the foliage base being a parameter because a surface model
cannot see under the leaves. DOSAVIÑA (Gil et al.) and PACE refine these with leaf density and sprayer
efficiency; vinecli converts the plain geometric expressions only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

__all__ = ["DOSE_KINDS", "HA_M2", "DoseExpr", "lwa_dose_from_rate", "lwa_m2_per_ha", "rate_from_lwa_dose",
           "rate_from_trv_dose", "rate_lpha", "row_litres_per_m", "trv_m3_per_ha"]

#: square metres in a hectare
HA_M2 = 10_000.0
#: the dose expressions a mission or a plan may give
DOSE_KINDS = ("rate", "lwa", "trv")

DoseKind = Literal["rate", "lwa", "trv"]


def _positive(name: str, v: float) -> float:
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name} must be finite and > 0, got {v!r}")
    return float(v)


def lwa_m2_per_ha(row_spacing_m: float, wall_height_m: float, sides: int = 2) -> float:
    """Leaf wall area, m² per ha of ground: 10 000 / spacing (m of row per ha) x leaf-wall height (m) x sides
    treated (1 or 2). EPPO PP 1/239(3)."""
    if sides not in (1, 2):
        raise ValueError(f"sides treated must be 1 or 2, got {sides!r}")
    return HA_M2 / _positive("row spacing", row_spacing_m) * max(float(wall_height_m), 0.0) * sides


def trv_m3_per_ha(row_spacing_m: float, wall_height_m: float, width_m: float) -> float:
    """Tree-row volume, m³ per ha of ground: leaf-wall height (m) x canopy width (m) x 10 000 / spacing (m)."""
    return max(float(wall_height_m), 0.0) * max(float(width_m), 0.0) * HA_M2 / _positive("row spacing", row_spacing_m)


def rate_from_lwa_dose(dose_l_per_10000m2: float, lwa_m2pha: float) -> float:
    """Application rate, L/ha of ground, of a label dose in L per 10 000 m² LWA on ``lwa_m2pha`` m²/ha."""
    return float(dose_l_per_10000m2) * max(float(lwa_m2pha), 0.0) / HA_M2


def lwa_dose_from_rate(rate_lpha: float, lwa_m2pha: float) -> float:
    """The dose per 10 000 m² LWA that a rate of ``rate_lpha`` L/ha of ground gives (inverse of
    :func:`rate_from_lwa_dose`); NaN without leaf wall."""
    return float(rate_lpha) * HA_M2 / lwa_m2pha if lwa_m2pha > 0.0 else math.nan


def rate_from_trv_dose(dose_l_per_10000m3: float, trv_m3pha: float) -> float:
    """Application rate, L/ha of ground, of a dose in L per 10 000 m³ TRV on ``trv_m3pha`` m³/ha."""
    return float(dose_l_per_10000m3) * max(float(trv_m3pha), 0.0) / HA_M2


def row_litres_per_m(rate_lpha: float, row_spacing_m: float) -> float:
    """Litres per metre of row of a rate in L/ha of ground: each metre of row stands for ``spacing`` m² of it."""
    return float(rate_lpha) * _positive("row spacing", row_spacing_m) / HA_M2


@dataclass(frozen=True)
class DoseExpr:
    """A dose as a mission or a plan gives it: ``kind`` "rate" (``value`` L/ha of ground), "lwa" (L per
    10 000 m² of leaf wall area) or "trv" (L per 10 000 m³ of tree-row volume); ``sides`` treated (LWA)."""

    kind: DoseKind
    value: float
    sides: int = 2

    def __post_init__(self) -> None:
        if self.kind not in DOSE_KINDS:
            raise ValueError(f"dose kind must be one of {DOSE_KINDS}, got {self.kind!r}")
        _positive("dose", self.value)
        if self.sides not in (1, 2):
            raise ValueError(f"sides treated must be 1 or 2, got {self.sides!r}")

    @property
    def units(self) -> str:
        """The unit the value is in."""
        return {"rate": "L/ha", "lwa": "L/10000 m2 LWA", "trv": "L/10000 m3 TRV"}[self.kind]

    def label(self) -> str:
        """``200 L/10000 m2 LWA (both sides)``."""
        sides = f" ({'both sides' if self.sides == 2 else 'one side'})" if self.kind == "lwa" else ""
        return f"{self.value:g} {self.units}{sides}"


def rate_lpha(dose: DoseExpr, row_spacing_m: float, wall_height_m: float, width_m: float) -> float:
    """The application rate, L/ha of ground, of ``dose`` over a canopy ``wall_height_m`` high and ``width_m``
    wide in rows ``row_spacing_m`` apart (a rate dose is its own value)."""
    if dose.kind == "rate":
        return dose.value
    if dose.kind == "lwa":
        return rate_from_lwa_dose(dose.value, lwa_m2_per_ha(row_spacing_m, wall_height_m, dose.sides))
    return rate_from_trv_dose(dose.value, trv_m3_per_ha(row_spacing_m, wall_height_m, width_m))
