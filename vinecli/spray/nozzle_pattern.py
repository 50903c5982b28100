"""The nozzle's own spray pattern: where a size class's drops start, and the shape they land on. SI units, ENU.

Hydraulic nozzles come in three patterns (ASABE S572 classes the drops, not the shape; the shapes are the
nozzle makers' catalogues: TeeJet Technologies, Catalog 51A, "spray pattern" of each nozzle type; Lefebvre 1989,
*Atomization and Sprays*, ch. 4 and 5, for how each is made):

* **full cone** — a vaned insert makes the liquid swirl and fill the cone: the drops leave along every ray
  within the cone's half angle θ/2 and land on a round, uniform disc;
* **hollow cone** — a swirl chamber (TeeJet ConeJet, Albuz ATR, Lechler TR, the HCI/HCA of Biglia et al. 2022)
  discharges a conical *sheet* with an air core: the drops leave on the cone's shell at θ/2, none in its core,
  and land on a ring ("hollow cone: circular ring pattern");
* **flat fan** — an elliptical orifice makes a flat *sheet* (TeeJet XR, TT, AI; Albuz AFC): θ across it (110°),
  a few degrees thick; its drops land on a line across the sheet's axis (boom nozzles are set with the sheet
  across the travel direction).

The drops of each ray stop within their ballistic reach ``r_b`` (:mod:`vinecli.spray.wake`: the ray's stopping
distance × sin(θ/2), at most the cone at the ground), and the rotor wake carries them down with the turbulent
spreading ``σ`` of a round jet. So the pattern survives where ``r_b`` is large against ``2σ`` (coarse drops keep
their momentum to the shell's edge: a 600 µm class of a 60° hollow cone lands on a ring of 1.6 m), and washes out
where it is small (fine drops stop within centimetres and the wake mixes them into one blob). The shape on the
ground is the pattern's start shape (disc r_b, ring r_b, line ±r_b) spread by the wake.

A parcel of a ring or a line is carried as ``k`` parts on it (equal volumes), each a disc of the wake's spreading
(radius ``2σ``, at least the parts' spacing so neighbours overlap): ``k`` from the shape's length over 2σ, at most
:data:`MAX_PARTS`; below :data:`MIN_PARTS` the shape is washed out and the parcel stays one disc with the shape's
variance (a ring's r_b²/2 per axis, a line's r_b²/3 along it, against a full disc's r_b²/4). Every consumer of
parcels (deposit grid, interception, collectors, swath) takes the parts as discs: volume is conserved exactly.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

__all__ = ["FLAT_FAN", "FULL_CONE", "HOLLOW_CONE", "MAX_PARTS", "PATTERN_CODES", "ShapedParcels", "expand_parts", "part_counts",
           "variance_factor"]

FULL_CONE, HOLLOW_CONE, FLAT_FAN = 0, 1, 2
PATTERN_CODES = {"full_cone": FULL_CONE, "hollow_cone": HOLLOW_CONE, "flat_fan": FLAT_FAN}
MAX_PARTS = 12  # parts of a ring or a line at most (cost: each part is a parcel)
PART_OVERLAP = 0.75  # a part's disc reaches at least this share of the spacing to its neighbours (they overlap)
#: fewer parts: the shape is washed out, one disc of its variance. A ring of radius r_b blurred by the wake's
#: Gaussian σ keeps a hollow centre only for r_b > √2 σ (the centre's curvature of ring ⊗ Gaussian changes sign
#: there), i.e. k = 2π r_b / 2σ > π √2 = 4.4; a line stays longer than wide from 2 r_b > 2σ on
MIN_PARTS = {HOLLOW_CONE: 5, FLAT_FAN: 2}
#: the start shape's variance per axis over r_b²/4 (a full disc's): ring 2, line 4/3 (along it)
_VARIANCE = {FULL_CONE: 1.0, HOLLOW_CONE: 2.0, FLAT_FAN: 4.0 / 3.0}


class ShapedParcels(Protocol):
    """What :func:`expand_parts` reads and writes of :class:`~vinecli.spray.deposition.Parcels`."""

    x: np.ndarray
    y: np.ndarray
    vol: np.ndarray
    radius: np.ndarray
    reach: np.ndarray
    wake_var: np.ndarray
    source: np.ndarray
    part_r: np.ndarray
    primaries: int


def variance_factor(pattern: np.ndarray) -> np.ndarray:
    """(n,) the pattern's variance per axis over a full disc's of the same reach (1, 2 ring, 4/3 line)."""
    return np.array([_VARIANCE[int(p)] for p in np.atleast_1d(pattern)], dtype=np.float64)


def part_counts(pattern: np.ndarray, reach: np.ndarray, wake_var: np.ndarray) -> np.ndarray:
    """(n, c) parts per nozzle and size class: the shape's length (ring 2π r_b, line 2 r_b) over the wake's 2σ
    (``wake_var`` = 4σ²), medians over the emission groups of ``reach`` and ``wake_var`` ((G, n, c), m and m²)."""
    pattern = np.asarray(pattern, dtype=np.int64)
    r = np.median(reach, axis=0)
    two_sigma = np.sqrt(np.maximum(np.median(wake_var, axis=0), 0.0))
    length = np.where(pattern[:, None] == HOLLOW_CONE, 2.0 * math.pi * r, np.where(pattern[:, None] == FLAT_FAN,
                                                                                  2.0 * r, 0.0))
    k = np.ceil(length / np.maximum(two_sigma, 0.05 * np.maximum(r, 1e-6)) - 1e-9).astype(np.int64)
    low = np.array([MIN_PARTS.get(int(p), 10**9) for p in pattern])[:, None]
    return np.where(k >= low, np.minimum(k, MAX_PARTS), 1)


def _unit_offsets(pattern: int, k: int) -> np.ndarray:
    """(k, 2) the parts' places in units of r_b, in the pattern's frame (first axis: the body's forward axis for a
    ring, the sheet's long axis for a fan): a ring's k points symmetric about the forward axis, a line's k cells."""
    if k <= 1:
        return np.zeros((1, 2))
    i = np.arange(k) + 0.5
    if pattern == HOLLOW_CONE:
        a = 2.0 * math.pi * i / k
        return np.stack([np.cos(a), np.sin(a)], axis=1)
    return np.stack([2.0 * i / k - 1.0, np.zeros(k)], axis=1)


def _spacing(pattern: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Distance between neighbouring parts in units of r_b (0 for one part)."""
    ring = 2.0 * np.sin(np.pi / np.maximum(k, 1))
    return np.where(k <= 1, 0.0, np.where(pattern == HOLLOW_CONE, ring, 2.0 / np.maximum(k, 1)))


# parameters: the parcels (updated in place), the nozzles' patterns and parts, the pattern axes of every group
def expand_parts(out: ShapedParcels, pattern: np.ndarray, counts: np.ndarray, axes: np.ndarray) -> None:
    """Replace each primary parcel of ``out`` (:class:`~vinecli.spray.deposition.Parcels`, primaries ordered
    (group, nozzle, class)) by its pattern's parts, in place: ``counts`` (n, c) from :func:`part_counts`,
    ``axes`` (G, n, 2) each nozzle's pattern axis in the world (unit, horizontal). The far field's parcels keep
    their order after the primaries; their ``source`` points at the first part of their primary. One-part parcels
    of a ring or a line take the shape's variance (their ``reach`` scaled by its square root)."""
    pattern = np.asarray(pattern, dtype=np.int64)
    n, c = counts.shape
    npri = int(out.primaries)
    g = npri // (n * c)
    total = int(out.vol.size)
    slot_j = np.repeat(np.arange(n), c)
    slot_pat = pattern[slot_j]
    per = counts.ravel()
    parent = np.repeat(np.arange(n * c), per)  # (P,) each part's (nozzle, class) slot
    unit = np.concatenate([_unit_offsets(int(slot_pat[s]), int(per[s])) for s in range(n * c)])  # (P, 2)
    p_count = parent.size
    take = np.concatenate([(np.arange(g)[:, None] * (n * c) + parent[None, :]).ravel(), np.arange(npri, total)])
    first = np.cumsum(per) - per  # each slot's first part
    new_of_parent = (np.arange(g)[:, None] * p_count + first[None, :]).ravel()
    for name, value in list(vars(out).items()):
        if isinstance(value, np.ndarray) and value.ndim == 1 and value.size == total:
            setattr(out, name, value[take])
    src = out.source
    far = np.arange(g * p_count, src.size)
    src[far] = np.where(src[far] >= 0, new_of_parent[np.clip(src[far], 0, max(new_of_parent.size - 1, 0))], -1)
    out.primaries = g * p_count
    m = g * p_count
    k = np.tile(per[parent], g)
    pat = np.tile(slot_pat[parent], g)
    rb = out.reach[:m].copy()
    wv = out.wake_var[:m]
    out.vol[:m] /= k
    a = axes[:, slot_j[parent], :].reshape(m, 2)  # (m, 2) the pattern's first axis
    u = np.tile(unit, (g, 1))
    ox = rb * (u[:, 0] * a[:, 0] - u[:, 1] * a[:, 1])
    oy = rb * (u[:, 0] * a[:, 1] + u[:, 1] * a[:, 0])
    out.x[:m] += ox
    out.y[:m] += oy
    spacing = rb * _spacing(pat, k)
    one = k <= 1
    reach = np.where(one, rb * np.sqrt(variance_factor(pat)), np.sqrt(np.maximum((PART_OVERLAP * spacing) ** 2 - wv, 0.0)))
    out.reach[:m] = reach
    out.radius[:m] = np.sqrt(reach * reach + wv)
    part_r = np.zeros(out.vol.size)
    part_r[:m] = np.hypot(ox, oy)
    out.part_r = part_r
