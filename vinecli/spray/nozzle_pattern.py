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

A ring blurred by the wake's Gaussian σ keeps a hollow centre only while r_b > √2 σ (where the centre's curvature
of ring ⊗ Gaussian changes sign); then the parcel lands on the **annulus** of the same mean radius and variance:
radii ``r_b ± a`` with ``a = √2 σ`` (a ring of radius R spread by a disc of radius 2σ has the per-axis variance
R²/2 + σ², the annulus (R_o² + R_i²)/4 = (R² + a²)/2). The annulus is a disc of radius R_o less one of radius R_i
(each uniform), so every consumer (deposit grid, interception, collectors, swath) takes it with two disc terms
(:func:`vinecli.spray.interception.annulus_cdf`, :func:`inner_radius`): one parcel, as cheap as a disc. A line
is carried as ``k`` parts on it (equal volumes), each a disc of the wake's spreading (radius ``2σ``, at least 0.75 of the parts' spacing so
neighbours overlap): ``k`` from its length over 2σ, at most :data:`MAX_PARTS`. A washed-out ring or line stays
one disc with the shape's variance (a ring's r_b²/2 per axis, a line's r_b²/3 along it, against a full disc's
r_b²/4). Volume is conserved exactly.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

__all__ = ["FLAT_FAN", "FULL_CONE", "HOLLOW_CONE", "MAX_PARTS", "PATTERN_CODES", "ShapedParcels",
           "expand_parts", "inner_radius", "part_counts", "variance_factor"]

FULL_CONE, HOLLOW_CONE, FLAT_FAN = 0, 1, 2
PATTERN_CODES = {"full_cone": FULL_CONE, "hollow_cone": HOLLOW_CONE, "flat_fan": FLAT_FAN}
MAX_PARTS = 8  # parts of a line at most (cost: each part is a parcel)
PART_OVERLAP = 0.75  # a part's disc reaches at least this share of the spacing to its neighbours (they overlap)
#: below: the shape is washed out, one disc of its variance. A ring (length 2π r_b) keeps its hollow centre for
#: r_b > √2 σ, i.e. 2π r_b / 2σ > π √2 = 4.4; a line (2 r_b) stays longer than wide from 2 r_b > 2σ on
MIN_LENGTH = {HOLLOW_CONE: math.pi * math.sqrt(2.0), FLAT_FAN: 1.0}  # the shape's length over 2σ
#: the start shape's variance per axis over r_b²/4 (a full disc's): ring 2, line 4/3 (along it)
_VARIANCE = np.array([1.0, 2.0, 4.0 / 3.0])


class ShapedParcels(Protocol):
    """What :func:`expand_parts` reads and writes of :class:`~vinecli.spray.deposition.Parcels`."""

    x: np.ndarray
    y: np.ndarray
    vol: np.ndarray
    radius: np.ndarray
    reach: np.ndarray
    wake_var: np.ndarray
    source: np.ndarray
    part_dx: np.ndarray
    part_dy: np.ndarray
    ring_r: np.ndarray
    primaries: int


def variance_factor(pattern: np.ndarray) -> np.ndarray:
    """The pattern's variance per axis over a full disc's of the same reach (1, ring 2, line 4/3), per element."""
    return _VARIANCE[np.asarray(pattern, dtype=np.int64)]


def inner_radius(radius: np.ndarray, ring_r: np.ndarray | None) -> np.ndarray | None:
    """Inner radius (m) of each parcel's annulus, ``2 R - R_o`` for a ring of mean radius ``ring_r`` (0: a disc);
    None when no parcel is a ring (``ring_r`` None, empty or all 0)."""
    if ring_r is None or ring_r.size != np.size(radius) or not np.any(ring_r > 0.0):
        return None
    return np.where(ring_r > 0.0, np.maximum(2.0 * ring_r - radius, 0.0), 0.0)


def part_counts(pattern: np.ndarray, reach: np.ndarray, wake_var: np.ndarray) -> np.ndarray:
    """(n, c) the shape's length over the wake's 2σ per nozzle and size class (ring 2π r_b, line 2 r_b; 0 for a
    full cone), from the medians over the emission groups of ``reach`` and ``wake_var`` = 4σ² ((G, n, c), m, m²)."""
    pattern = np.asarray(pattern, dtype=np.int64)
    r = np.median(reach, axis=0)
    two_sigma = np.sqrt(np.maximum(np.median(wake_var, axis=0), 0.0))
    length = np.where(pattern[:, None] == HOLLOW_CONE, 2.0 * math.pi * r, np.where(pattern[:, None] == FLAT_FAN,
                                                                                  2.0 * r, 0.0))
    return length / np.maximum(two_sigma, 0.05 * np.maximum(r, 1e-6))


def _line_offsets(k: int) -> np.ndarray:
    """(k,) the parts' places along a line in units of r_b: the middles of k equal cells of [-1, 1]."""
    return 2.0 * (np.arange(k) + 0.5) / k - 1.0


# parameters: the parcels (updated in place), the nozzles' patterns, the shapes' lengths, the fans' axes
def expand_parts(out: ShapedParcels, pattern: np.ndarray, lengths: np.ndarray, axes: np.ndarray) -> None:
    """Give each primary parcel of ``out`` (:class:`~vinecli.spray.deposition.Parcels`, primaries ordered (group,
    nozzle, class)) its pattern's shape, in place: ``lengths`` (n, c) from :func:`part_counts`; ``axes`` (G, n, 2)
    each nozzle's fan axis in the world (unit, horizontal). A ring that survives the wake lands on its annulus
    (``ring_r`` its mean radius, ``radius`` the outer one, ``reach`` so that the plume narrows upwards as a disc's
    would); a line on ``k`` parts (the far field's parcels keep their order after the primaries, their ``source``
    pointing at the first part of their primary); a washed-out shape on one disc of its variance. Sets
    ``part_dx``, ``part_dy`` (a part's offset from its pattern's centre, m) and ``ring_r`` (m; 0 otherwise)."""
    pattern = np.asarray(pattern, dtype=np.int64)
    n, c = lengths.shape
    npri = int(out.primaries)
    g = npri // (n * c)
    total = int(out.vol.size)
    slot_pat = np.repeat(pattern, c)
    length = lengths.ravel()
    shaped = length > np.array([MIN_LENGTH.get(int(p), math.inf) for p in slot_pat])
    per = np.where(shaped & (slot_pat == FLAT_FAN), np.minimum(np.ceil(length - 1e-9), MAX_PARTS), 1).astype(np.int64)
    parent = np.repeat(np.arange(n * c), per)  # (P,) each part's (nozzle, class) slot
    p_count = parent.size
    if p_count > n * c:
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
    else:  # the transport's arrays may be read-only views
        out.x, out.y, out.vol, out.reach, out.radius = (a.copy() for a in (out.x, out.y, out.vol, out.reach, out.radius))
    m = g * p_count
    k = np.tile(per[parent], g)
    pat = np.tile(slot_pat[parent], g)
    ring = np.tile(shaped[parent], g) & (pat == HOLLOW_CONE)
    line = k > 1
    rb = out.reach[:m].copy()
    wv = out.wake_var[:m]
    out.vol[:m] /= k
    u = np.concatenate([_line_offsets(int(kk)) for kk in per])  # (P,) the parts' places along their line
    a = axes[:, np.repeat(np.arange(n), c)[parent], :].reshape(m, 2)
    off = np.where(line, rb * np.tile(u, g), 0.0)
    ox, oy = off * a[:, 0], off * a[:, 1]
    out.x[:m] += ox
    out.y[:m] += oy
    outer = rb + np.sqrt(0.5 * wv)  # the annulus: r_b ± √2 σ
    spacing = 2.0 * rb / k
    reach = np.where(ring, np.sqrt(np.maximum(outer * outer - wv, 0.0)),
                     np.where(line, np.sqrt(np.maximum((PART_OVERLAP * spacing) ** 2 - wv, 0.0)),
                              rb * np.sqrt(variance_factor(pat))))
    out.reach[:m] = reach
    out.radius[:m] = np.sqrt(reach * reach + wv)
    for name, head in (("part_dx", ox), ("part_dy", oy), ("ring_r", np.where(ring, rb, 0.0))):
        full = np.zeros(out.vol.size)
        full[:m] = head
        setattr(out, name, full)
