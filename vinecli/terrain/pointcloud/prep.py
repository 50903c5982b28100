"""Cleaning and measuring a point cloud: NaN/inf, exact duplicates, filters, spacing, voxel size.

All functions are pure numpy/scipy on (N, 3) float64 arrays and return new arrays plus counts.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vinecli.errors import InputError, TerrainError

log = logging.getLogger(__name__)

#: Points used to estimate nearest-neighbour spacing (query sample; the tree holds every point).
SPACING_SAMPLE = 200_000


def finite_mask(xyz: np.ndarray) -> np.ndarray:
    """True for points whose three coordinates are finite."""
    return np.all(np.isfinite(xyz), axis=1)


def unique_mask(xyz: np.ndarray) -> np.ndarray:
    """True for the first occurrence of each exactly repeated (x, y, z); False for later copies."""
    n = len(xyz)
    if n < 2:
        return np.ones(n, dtype=bool)
    order = np.lexsort((xyz[:, 2], xyz[:, 1], xyz[:, 0]))
    s = xyz[order]
    same_as_prev = np.empty(n, dtype=bool)
    same_as_prev[0] = False
    same_as_prev[1:] = np.all(s[1:] == s[:-1], axis=1)
    keep = np.empty(n, dtype=bool)
    keep[order] = ~same_as_prev
    return keep


def class_mask(classification: np.ndarray | None, classes: Sequence[int], path: Path) -> np.ndarray:
    """True for points whose classification is in ``classes``; the cloud must carry classes."""
    if classification is None:
        raise InputError("--classes needs a classification attribute, and this cloud has none", path=path)
    return np.isin(classification, np.asarray(list(classes), dtype=np.int64))


def bbox_mask(xyz: np.ndarray, bbox: Sequence[float], path: Path) -> np.ndarray:
    """True for points inside ``(minx, miny, maxx, maxy)`` (file CRS units, edges included)."""
    minx, miny, maxx, maxy = (float(v) for v in bbox)
    if not (minx < maxx and miny < maxy):
        raise InputError(f"--bbox must be minx,miny,maxx,maxy with min < max, got {list(bbox)}", path=path)
    return (xyz[:, 0] >= minx) & (xyz[:, 0] <= maxx) & (xyz[:, 1] >= miny) & (xyz[:, 1] <= maxy)


def require_surface(xyz: np.ndarray, path: Path, *, what: str, plan_view: bool = False) -> None:
    """Raise TerrainError unless there are >= 3 points that are not all collinear (in x-y if ``plan_view``)."""
    n = len(xyz)
    if n < 3:
        raise TerrainError(f"only {n} point{'s' if n != 1 else ''} {what} (need at least 3 non-collinear points)",
                           path=path)
    pts = xyz[:, :2] if plan_view else xyz
    sample = pts if n <= 100_000 else pts[np.random.default_rng(0).choice(n, 100_000, replace=False)]
    c = sample - sample.mean(axis=0)
    s = np.linalg.svd(c, compute_uv=False)
    if s[0] == 0.0 or s[1] <= 1e-9 * s[0]:
        where = "in plan view (x-y)" if plan_view else ""
        raise TerrainError(f"all {n} points {what} are collinear or coincident {where}".rstrip()
                           + " - no surface to mesh", path=path)


def nn_spacing(xyz: np.ndarray, *, sample: int = SPACING_SAMPLE, seed: int = 0) -> tuple[float, float]:
    """(mean, median) 3-D nearest-neighbour distance in the units of ``xyz``.

    The KD-tree holds every point; distances are measured for a random sample of at most
    ``sample`` query points (deterministic for a seed).
    """
    from scipy.spatial import cKDTree

    n = len(xyz)
    if n < 2:
        return (math.nan, math.nan)
    tree = cKDTree(xyz)
    q = xyz if n <= sample else xyz[np.random.default_rng(seed).choice(n, sample, replace=False)]
    dist, _ = tree.query(q, k=2)
    d = dist[:, 1]
    d = d[d > 0] if np.any(d > 0) else d
    return (float(np.mean(d)), float(np.median(d)))


def default_voxel(median_nn: float) -> float:
    """Default voxel edge (m): twice the median nearest-neighbour spacing.

    For points spread over a 2.5-D surface with density rho, the median NN distance is about
    0.47/sqrt(rho), so 2x is ~1/sqrt(rho): each voxel column holds about one point on average.
    This evens out over-dense patches (photogrammetry, overlapping flight lines) and averages
    noise, while sparse areas keep their points.
    """
    return 2.0 * median_nn


def voxel_count(xyz: np.ndarray, voxel: float) -> int:
    """Number of occupied voxels of edge ``voxel`` (= points after Open3D's voxel_down_sample).

    Uses Open3D's grid origin (minimum bound minus half a voxel).
    """
    if len(xyz) == 0:
        return 0
    idx = np.floor((xyz - (xyz.min(axis=0) - 0.5 * voxel)) / voxel).astype(np.int64)
    dims = idx.max(axis=0) + 1
    if float(dims[0]) * float(dims[1]) * float(dims[2]) < 2**62:
        key = (idx[:, 0] * dims[1] + idx[:, 1]) * dims[2] + idx[:, 2]
        return int(len(np.unique(key)))
    return int(len(np.unique(idx, axis=0)))


def voxel_for_max_points(xyz: np.ndarray, voxel: float, max_points: int) -> float:
    """Smallest voxel (>= ``voxel``, grown geometrically) that leaves at most ``max_points`` points.

    A surface cloud's voxel count falls roughly as 1/voxel^2, so each step scales the voxel by
    sqrt(count / max_points) (plus 2%) until the count fits.
    """
    if max_points < 3:
        raise InputError(f"--max-points must be at least 3, got {max_points}")
    v = voxel
    for _ in range(40):
        count = voxel_count(xyz, v)
        if count <= max_points:
            return v
        v *= max(1.02, math.sqrt(count / max_points) * 1.02)
    return v
