"""Spray-quality metrics of a run's deposition (docs/deposition.md), world ENU, litres, L/ha.

Everything is measured on the deposition grid (cell centres), the off-grid volume counting as
outside the fence. Row bands: each targeted row polyline ± half the canopy width. Along each row the band is cut
into ``segment_m`` pieces; a piece's rate is the volume of the grid cells whose centres lie in
it divided by their area (L/ha). A row is *sprayed* when one of its pieces got at least half the
nominal rate; its *sprayed stretch* runs from the first to the last such piece. Mean rate and
CV (ASABE S386.2 style: std / mean of the collector values) are over the pieces of the sprayed
stretches; coverage is the share of the targeted rows' length that got ≥ 50 % of the nominal rate.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from vinecli.physics.deposit_grid import GridSpec

__all__ = ["DEPOSIT_METRICS", "deposition_metrics", "points_in_polygon", "row_profiles"]

Polyline = Sequence[tuple[float, float]]

#: name -> (unit, description); registered in vinecli.missions.metrics.METRICS
DEPOSIT_METRICS: dict[str, tuple[str, str]] = {
    "deposit_emitted_l": ("L", "Spray volume emitted by the nozzles (= tank volume drained while spraying), L"),
    "deposit_on_grid_l": ("L", "Emitted volume that landed on the deposition grid, L"),
    "deposit_off_grid_l": ("L", "Emitted volume that landed beyond the deposition grid, L"),
    "deposit_balance_error": ("1", "|emitted - on grid - off grid| / emitted (volume balance, <= 1e-6 by construction)"),
    "deposit_on_rows_fraction": ("1", "Share of the emitted volume landing on the canopy: within a row band (row ± canopy width / 2) of any row"),
    "row_coverage_fraction": ("1", "Share of the targeted rows' length that received >= 50 % of the nominal rate"),
    "mean_rate_lpha_on_rows": ("L/ha", "Mean application rate along the sprayed stretches of the rows, L/ha"),
    "deposit_cv_on_rows": ("1", "Coefficient of variation of the rate along the sprayed stretches of the rows"),
    "drift_outside_fence_fraction": ("1", "Share of the emitted volume landing outside the geofence (or the field)"),
    "nominal_rate_lpha": ("L/ha", "Rate the spray phase asked for (rate_lpha, or 10 000 q / (v track width)), L/ha"),
    "spray_swath_m": ("m", "Geometric swath of the nozzles at the spray height, m"),
    "spray_track_width_m": ("m", "Width one pass doses: the swath, or the row spacing when the rows are closer, m"),
    "deposit_centroid_offset_east_m": ("m", "Deposit centroid minus the volume-weighted nozzle path centroid, east, m"),
    "deposit_centroid_offset_north_m": ("m", "Deposit centroid minus the volume-weighted nozzle path centroid, north, m"),
}


def points_in_polygon(x: np.ndarray, y: np.ndarray, poly: Sequence[tuple[float, float]]) -> np.ndarray:
    """Even-odd ray casting, vectorised over the points (ENU m); boolean mask."""
    inside = np.zeros(np.shape(x), dtype=bool)
    pts = np.asarray(poly, dtype=np.float64)
    n = len(pts)
    for i in range(n):
        x1, y1 = pts[i]
        x2, y2 = pts[(i + 1) % n]
        if y1 == y2:
            continue
        cond = (y1 > y) != (y2 > y)
        xint = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
        inside ^= cond & (x < xint)
    return inside


def _dist_along(px: np.ndarray, py: np.ndarray, line: Polyline) -> tuple[np.ndarray, np.ndarray]:
    """Distance to the polyline and the arc length of the nearest point (m)."""
    pts = np.asarray(line, dtype=np.float64)
    best = np.full(px.shape, np.inf)
    s_best = np.zeros(px.shape)
    s0 = 0.0
    for (ax, ay), (bx, by) in zip(pts[:-1], pts[1:], strict=True):
        dx, dy = bx - ax, by - ay
        seg = math.hypot(dx, dy)
        if seg <= 0:
            continue
        u = np.clip(((px - ax) * dx + (py - ay) * dy) / (seg * seg), 0.0, 1.0)
        d = np.hypot(px - (ax + u * dx), py - (ay + u * dy))
        better = d < best
        best = np.where(better, d, best)
        s_best = np.where(better, s0 + u * seg, s_best)
        s0 += seg
    return best, s_best


def row_profiles(grid: GridSpec, volume_l: np.ndarray, rows: Sequence[Polyline], half_width_m: float,
                 segment_m: float = 0.5) -> list[dict[str, Any]]:
    """Per row: ``s_m`` (segment centres along the row, m) and ``rate_lpha`` (NaN where no grid cell)."""
    xc, yc = grid.centres()
    out = []
    for line in rows:
        pts = np.asarray(line, dtype=np.float64)
        length = float(np.sum(np.hypot(*np.diff(pts, axis=0).T)))
        nseg = max(1, int(math.ceil(length / segment_m - 1e-9)))
        ix0 = max(int(np.searchsorted(xc, pts[:, 0].min() - half_width_m - grid.cell)), 0)
        ix1 = int(np.searchsorted(xc, pts[:, 0].max() + half_width_m + grid.cell))
        iy0 = max(int(np.searchsorted(yc, pts[:, 1].min() - half_width_m - grid.cell)), 0)
        iy1 = int(np.searchsorted(yc, pts[:, 1].max() + half_width_m + grid.cell))
        vol = np.zeros(nseg)
        area = np.zeros(nseg)
        if ix1 > ix0 and iy1 > iy0:
            gx, gy = np.meshgrid(xc[ix0:ix1], yc[iy0:iy1])
            d, s = _dist_along(gx, gy, line)
            band = (d <= half_width_m) & (s > 0.0) & (s < length)
            k = np.minimum((s[band] / segment_m).astype(np.int64), nseg - 1)
            vol = np.bincount(k, weights=volume_l[iy0:iy1, ix0:ix1][band], minlength=nseg)
            area = np.bincount(k, minlength=nseg) * grid.cell * grid.cell
        with np.errstate(invalid="ignore", divide="ignore"):
            rate = np.where(area > 0, vol / area * 1e4, np.nan)
        seg_len = np.full(nseg, segment_m)
        seg_len[-1] = length - segment_m * (nseg - 1)
        out.append({"length_m": length, "s_m": (np.arange(nseg) + 0.5) * segment_m, "seg_len_m": seg_len,
                    "rate_lpha": rate})
    return out


def deposition_metrics(dep: Any, rows: Sequence[Polyline], canopy_width_m: float,
                       fence: Sequence[tuple[float, float]] | None, nominal_rate_lpha: float,
                       segment_m: float = 0.5, canopy_rows: Sequence[Polyline] | None = None,
                       ) -> tuple[dict[str, float], list[dict[str, Any]]]:
    """(metrics, per-row figures) of a :class:`~vinecli.sim.deposition.DepositionResult`.

    ``rows``: the rows the mission targeted (coverage, mean rate, CV, per-row figures);
    ``canopy_rows``: every row of the field (the on-row fraction: liquid on any vine), default ``rows``.
    """
    p = dep.parcels
    em = float(dep.emitted_l)
    nan = math.nan
    m: dict[str, float] = {
        "deposit_emitted_l": em, "deposit_on_grid_l": float(dep.on_grid_l), "deposit_off_grid_l": float(dep.off_grid_l),
        "deposit_balance_error": float(dep.balance_error), "nominal_rate_lpha": float(nominal_rate_lpha),
    }
    vol = p.vol
    if em > 0 and vol.size:
        cx, cy = float(np.dot(p.x, vol) / vol.sum()), float(np.dot(p.y, vol) / vol.sum())
        path = p.path_xy
        m["deposit_centroid_offset_east_m"] = cx - float(np.mean(path[:, 0])) if path.size else nan
        m["deposit_centroid_offset_north_m"] = cy - float(np.mean(path[:, 1])) if path.size else nan
    hw = 0.5 * canopy_width_m
    xc, yc = dep.grid.centres()
    gx, gy = np.meshgrid(xc, yc)
    canopy = list(canopy_rows) if canopy_rows else list(rows)
    if canopy and em > 0:
        from vinecli.rows.geometry import point_polyline_distance

        band = point_polyline_distance(gx, gy, canopy) <= hw
        m["deposit_on_rows_fraction"] = float(dep.volume_l[band].sum() / em)
    else:
        m["deposit_on_rows_fraction"] = nan
    poly = list(fence) if fence else None
    if poly is None and canopy:  # no fence: the field = the rows' bounding box grown by half the canopy width
        allp = np.asarray([q for r in canopy for q in r], dtype=np.float64)
        x0, y0 = allp.min(axis=0) - hw
        x1, y1 = allp.max(axis=0) + hw
        poly = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    if poly and em > 0:  # volume beyond the grid (>= margin_m from the sprayed path) counts as outside
        outside = ~points_in_polygon(gx, gy, poly)
        m["drift_outside_fence_fraction"] = float((dep.volume_l[outside].sum() + dep.off_grid_l) / em)
    else:
        m["drift_outside_fence_fraction"] = nan
    profiles = row_profiles(dep.grid, dep.volume_l, rows, hw, segment_m) if rows else []
    half = 0.5 * nominal_rate_lpha
    tot_len = cov_len = 0.0
    stretch: list[np.ndarray] = []
    for i, pr in enumerate(profiles):
        r = pr["rate_lpha"]
        ok = np.nan_to_num(r, nan=0.0) >= half if nominal_rate_lpha > 0 else np.zeros(r.shape, bool)
        tot_len += pr["length_m"]
        cov_len += float(pr["seg_len_m"][ok].sum())
        pr["row"] = i
        pr["covered_fraction"] = float(pr["seg_len_m"][ok].sum() / pr["length_m"]) if pr["length_m"] > 0 else nan
        idx = np.flatnonzero(ok)
        if idx.size:
            seg = r[idx[0]:idx[-1] + 1]
            seg = seg[np.isfinite(seg)]
            stretch.append(seg)
            pr["sprayed_m"] = [float(pr["s_m"][idx[0]]), float(pr["s_m"][idx[-1]])]
            pr["mean_rate_lpha"] = float(np.mean(seg))
        else:
            pr["sprayed_m"] = None
            pr["mean_rate_lpha"] = float(np.nanmean(r)) if np.isfinite(r).any() else nan
    m["row_coverage_fraction"] = cov_len / tot_len if tot_len > 0 else nan
    if stretch:
        allr = np.concatenate(stretch)
        mean = float(np.mean(allr))
        m["mean_rate_lpha_on_rows"] = mean
        m["deposit_cv_on_rows"] = float(np.std(allr) / mean) if mean > 0 else nan
    else:
        m["mean_rate_lpha_on_rows"] = nan
        m["deposit_cv_on_rows"] = nan
    return m, profiles
