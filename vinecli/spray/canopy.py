"""Vine rows as porous hedges: height, width, leaf area density and its vertical profile. SI, world ENU.

Each row's canopy is a hedge of rectangular cross-section along its polyline: foliage from
``base_m`` to ``top_m`` above the ground, ``width_m`` across, filled with leaves at a leaf area
density (LAD, one-sided leaf area per canopy volume, m²/m³) that varies with height by a relative
``profile`` (equal-height layers from the base up, mean 1). The leaf area index of the row
(leaf area per ground area of the field) is ``LAD · width · (top - base) / row spacing``.

Defaults by growth stage (BBCH, Lorenz et al. 1995, Vitis vinifera), vertical shoot positioned
(VSP) trellis; :data:`BBCH_DEFAULTS`. Sources:

* the full canopy (BBCH 81-89): Biglia et al. 2022, Sci. Total Environ. 845:157292, §2.4 (cv.
  Barbera, BBCH 89, point-quadrat measurements): vine height 2.21 m, vegetative strip 1.68 m, canopy
  width 0.55 m, LAI 1.5-1.9 at 2.5 m row spacing, i.e. LAD = 1.7 · 2.5 / (0.55 · 1.68) ≈ 4.6 m²/m³;
* the LAD range of well-balanced single-canopy trellises, 3-7 m²/m³ (Kliewer & Dokoozlian 2005,
  Am. J. Enol. Vitic. 56:170-181), which the full-canopy value lies in;
* before bud burst (BBCH ≤ 09) there is no foliage (LAD 0).

The stages in between are this model's assumption (stated in docs/budget.md): the foliage grows
from the cordon (~0.9 m) up and out to the trimmed full canopy, LAD rising linearly with it. Measure
your own vineyard where it matters: every field can be given, per world or per row.

Characteristic leaf width (impaction, :mod:`vinecli.spray.interception`): 0.12 m, a grapevine leaf
blade of 10-15 cm. Leaf-angle factor ``G`` = 0.5: the projection of a spherical (random) leaf-angle
distribution, the same in every direction (Ross 1981; Campbell & Norman 1998, §15.2).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from vinecli.spray.deposit_grid import GridSpec

__all__ = ["BBCH_DEFAULTS", "Canopy", "Hedge", "HedgeDims", "bbch_dims", "hedge_window", "measure_row_heights",
           "row_spacing"]

Polyline = Sequence[tuple[float, float]]
HeightFn = Callable[[np.ndarray, np.ndarray], np.ndarray]

G_SPHERICAL = 0.5
LEAF_WIDTH_M = 0.12


@dataclass(frozen=True)
class HedgeDims:
    """Canopy dimensions at one growth stage: foliage base and top above the ground (m), width (m), LAD (m²/m³)."""

    base_m: float
    top_m: float
    width_m: float
    lad_m2m3: float


#: BBCH stage (lower bound of a range) -> dimensions; a stage takes the entry at or below it
BBCH_DEFAULTS: dict[int, HedgeDims] = {
    0: HedgeDims(0.9, 0.9, 0.0, 0.0),      # dormant to bud burst (00-09): no leaves
    11: HedgeDims(0.85, 1.15, 0.30, 1.0),  # leaves unfolding (11-19)
    53: HedgeDims(0.75, 1.45, 0.35, 2.0),  # inflorescences visible/separated (53-57)
    61: HedgeDims(0.60, 1.85, 0.45, 3.0),  # flowering (61-69)
    71: HedgeDims(0.55, 2.15, 0.50, 4.0),  # fruit development, bunch closure (71-79), trimmed
    81: HedgeDims(0.53, 2.21, 0.55, 4.6),  # ripening (81-89): Biglia et al. 2022 §2.4, BBCH 89
}


def bbch_dims(stage: int) -> HedgeDims:
    """Default dimensions at BBCH ``stage`` (0-99): the table entry at or below it."""
    if not 0 <= stage <= 99:
        raise ValueError(f"BBCH stage must be 0-99, got {stage}")
    return BBCH_DEFAULTS[max(k for k in BBCH_DEFAULTS if k <= stage)]


@dataclass(frozen=True)
class Hedge:
    """One row's canopy: foliage ``base_m``..``top_m`` above the ground, ``width_m`` across, mean LAD m²/m³."""

    row: int
    base_m: float
    top_m: float
    width_m: float
    lad_m2m3: float

    @property
    def depth_m(self) -> float:
        """Height of the foliage layer, m."""
        return max(self.top_m - self.base_m, 0.0)

    def leaf_area_per_m(self) -> float:
        """One-sided leaf area per metre of row, m²/m."""
        return self.lad_m2m3 * self.width_m * self.depth_m


@dataclass(frozen=True)
class Canopy:
    """Every row's hedge, the shared vertical LAD profile and the leaf properties.

    ``rows``: the row polylines (ENU m) the hedges stand on, ``hedges[i].row`` indexes them.
    ``profile``: relative LAD of equal-height layers from base to top (normalised to mean 1).
    """

    rows: tuple[tuple[tuple[float, float], ...], ...]
    hedges: tuple[Hedge, ...]
    profile: tuple[float, ...] = (1.0,)
    g_factor: float = G_SPHERICAL
    leaf_width_m: float = LEAF_WIDTH_M
    source: str = "bbch"  # "bbch" | "chm" | "given"
    bbch: int | None = None
    spacing_m: float = math.nan
    notes: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        p = np.asarray(self.profile, dtype=np.float64)
        if p.size == 0 or np.any(p < 0) or not np.all(np.isfinite(p)) or p.sum() <= 0:
            raise ValueError("the LAD profile needs at least one layer, finite and >= 0, not all 0")
        object.__setattr__(self, "profile", tuple(float(v) for v in p / p.mean()))

    @property
    def has_foliage(self) -> bool:
        return any(h.lad_m2m3 > 0 and h.width_m > 0 and h.depth_m > 0 for h in self.hedges)

    @property
    def displacement_m(self) -> float:
        """Zero-plane displacement of the wind over the rows, m: 2/3 of the hedges' mean top (Brutsaert 1982,
        *Evaporation into the Atmosphere*, §5.2; 0 without foliage)."""
        tops = [h.top_m for h in self.hedges if h.lad_m2m3 > 0 and h.width_m > 0 and h.depth_m > 0]
        return 2.0 / 3.0 * float(np.mean(tops)) if tops else 0.0

    def row_length_m(self, i: int) -> float:
        pts = np.asarray(self.rows[i], dtype=np.float64)
        return float(np.sum(np.hypot(*np.diff(pts, axis=0).T))) if len(pts) >= 2 else 0.0

    def leaf_area_m2(self, i: int) -> float:
        """One-sided leaf area of row ``i``'s hedge, m²."""
        return self.hedges[i].leaf_area_per_m() * self.row_length_m(i)

    def lai(self) -> float:
        """Leaf area index of the field: mean leaf area per m of row over the row spacing (NaN: one row)."""
        if not self.hedges or not math.isfinite(self.spacing_m) or self.spacing_m <= 0:
            return math.nan
        return float(np.mean([h.leaf_area_per_m() for h in self.hedges]) / self.spacing_m)

    def to_dict(self) -> dict[str, object]:
        """The resolved canopy as world.json ``canopy`` (without the row polylines: they are ``vine_rows_enu``)."""
        return {"source": self.source, "bbch": self.bbch, "profile": list(self.profile), "g_factor": self.g_factor,
                "leaf_width_m": self.leaf_width_m, "spacing_m": self.spacing_m, "lai": self.lai(),
                "notes": list(self.notes),
                "hedges": [{"row": h.row, "base_m": h.base_m, "top_m": h.top_m, "width_m": h.width_m,
                            "lad_m2m3": h.lad_m2m3} for h in self.hedges]}

    @classmethod
    def from_dict(cls, d: dict[str, object], rows: Sequence[Polyline]) -> Canopy:
        hedges = tuple(Hedge(int(h["row"]), float(h["base_m"]), float(h["top_m"]), float(h["width_m"]),  # type: ignore[index]
                             float(h["lad_m2m3"])) for h in d.get("hedges", []))  # type: ignore[attr-defined]
        return cls(rows=tuple(tuple((float(p[0]), float(p[1])) for p in r) for r in rows), hedges=hedges,
                   profile=tuple(d.get("profile") or (1.0,)),  # type: ignore[arg-type]
                   g_factor=float(d.get("g_factor", G_SPHERICAL)),  # type: ignore[arg-type]
                   leaf_width_m=float(d.get("leaf_width_m", LEAF_WIDTH_M)),  # type: ignore[arg-type]
                   source=str(d.get("source", "bbch")), bbch=d.get("bbch"),  # type: ignore[arg-type]
                   spacing_m=float(d.get("spacing_m", math.nan)),  # type: ignore[arg-type]
                   notes=tuple(d.get("notes") or ()))  # type: ignore[arg-type]


def hedge_window(grid: GridSpec, canopy: Canopy | None) -> GridSpec:
    """The cells of ``grid`` over the hedges (their rows' extent + width + 2 cells), same alignment; the whole
    grid when there are no hedges. The budget's canopy maps (:mod:`vinecli.runs.budget_out`) need no more."""
    if canopy is None or not canopy.hedges:
        return grid
    pts = np.vstack([np.asarray(r, dtype=np.float64) for r in canopy.rows if len(r)])
    pad = max(h.width_m for h in canopy.hedges) + 2 * grid.cell
    ix0 = max(int(np.floor((pts[:, 0].min() - pad - grid.x0) / grid.cell)), 0)
    iy0 = max(int(np.floor((pts[:, 1].min() - pad - grid.y0) / grid.cell)), 0)
    ix1 = min(int(np.ceil((pts[:, 0].max() + pad - grid.x0) / grid.cell)), grid.nx)
    iy1 = min(int(np.ceil((pts[:, 1].max() + pad - grid.y0) / grid.cell)), grid.ny)
    if ix1 <= ix0 or iy1 <= iy0:
        return grid
    return GridSpec(grid.x0 + ix0 * grid.cell, grid.y0 + iy0 * grid.cell, grid.cell, ix1 - ix0, iy1 - iy0)


def row_spacing(rows: Sequence[Polyline]) -> float:
    """Median distance between neighbouring rows' midpoints across the row direction, m (NaN for < 2 rows)."""
    mids = [np.mean(np.asarray(r, dtype=float), axis=0) for r in rows if len(r) >= 2]
    if len(mids) < 2:
        return math.nan
    r0 = np.asarray(rows[0], dtype=float)
    u = r0[-1] - r0[0]
    u = u / (np.linalg.norm(u) or 1.0)
    across = np.sort([float(-u[1] * m[0] + u[0] * m[1]) for m in mids])
    gaps = np.diff(across)
    gaps = gaps[gaps > 1e-3]
    return float(np.median(gaps)) if gaps.size else math.nan


def measure_row_heights(height: HeightFn, rows: Sequence[Polyline], width_m: float, spacing_m: float,
                        step_m: float = 0.25) -> list[float]:
    """Canopy height of each row from a surface model (m): the canopy height model along the row.

    Every ``step_m`` along the row: the highest surface across the canopy band (± width/2) minus the
    lowest surface in the middle of the inter-rows on either side (± spacing/2, the bare ground);
    a row's height is the median over its length (0 where the survey shows no canopy).
    """
    out = []
    half_w, half_s = 0.5 * width_m, 0.5 * spacing_m
    for line in rows:
        pts = np.asarray(line, dtype=np.float64)
        seg = np.diff(pts, axis=0)
        lens = np.hypot(seg[:, 0], seg[:, 1])
        total = float(lens.sum())
        if total <= 0:
            out.append(0.0)
            continue
        s = np.arange(0.5 * step_m, total, step_m)
        cum = np.concatenate([[0.0], np.cumsum(lens)])
        k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(lens) - 1)
        t = (s - cum[k]) / np.where(lens[k] > 0, lens[k], 1.0)
        p = pts[k] + seg[k] * t[:, None]
        d = seg[k] / np.where(lens[k] > 0, lens[k], 1.0)[:, None]
        nrm = np.stack([-d[:, 1], d[:, 0]], axis=1)
        across = np.linspace(-half_w, half_w, 5)
        top = np.max([height(p[:, 0] + a * nrm[:, 0], p[:, 1] + a * nrm[:, 1]) for a in across], axis=0)
        ground_off = [sgn * half_s + e for sgn in (-1.0, 1.0) for e in (-0.1 * half_s, 0.0, 0.1 * half_s)]
        ground = np.min([height(p[:, 0] + a * nrm[:, 0], p[:, 1] + a * nrm[:, 1]) for a in ground_off], axis=0)
        out.append(max(float(np.median(top - ground)), 0.0))
    return out
