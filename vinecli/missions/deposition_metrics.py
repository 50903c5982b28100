"""Spray-quality metrics of a run's deposition (docs/deposition.md), world ENU, litres, L/ha.

Everything is measured on the deposition grid (cell centres), the off-grid volume counting as
outside the fence. Row bands: each targeted row polyline ± half the canopy width. Along each row the band is cut
into ``segment_m`` pieces; a piece's rate is the volume of the grid cells whose centres lie in
it divided by their area (L/ha). Each row has a *planned stretch* (start, end along the row, m: the
part the plan sprays, i.e. the row clipped to the fence and the terrain; the whole row without a
plan): the dose is judged there. A row's mean rate and the CV (ASABE S386.2 style: std / mean of the
collector values) are over the pieces of its planned stretch; coverage is the share of the planned
stretches that got ≥ 50 % of the nominal rate; the dose windows are ``window_m`` long runs of pieces
inside the planned stretch (their mean against the asked rate: hot spots and gaps). Every fraction
lies in [0, 1].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from vinecli.geometry import Polyline, distance_along, points_in_polygon, segments
from vinecli.spray.deposit_grid import GridSpec

if TYPE_CHECKING:
    from vinecli.sim.spray_deposit import DepositionResult

__all__ = ["DEPOSIT_METRICS", "deposition_metrics", "near_polylines", "no_spray_fraction", "row_profiles"]


#: name -> (unit, description); registered in vinecli.missions.metrics.METRICS
DEPOSIT_METRICS: dict[str, tuple[str, str]] = {
    "deposit_emitted_l": ("L", "Spray volume emitted by the nozzles (= tank volume drained while spraying), L"),
    "deposit_on_grid_l": ("L", "Emitted volume that landed on the deposition grid, L"),
    "deposit_off_grid_l": ("L", "Emitted volume that landed beyond the deposition grid, L"),
    "deposit_balance_error": ("1", "|emitted - on grid - off grid| / emitted (volume balance, <= 1e-6 by construction)"),
    "deposit_on_rows_fraction": ("1", "Share of the emitted volume landing on the canopy: within a row band (row ± canopy width / 2) of any row"),
    "row_coverage_fraction": ("1", "Share of the rows' planned stretches that received >= 50 % of the nominal rate"),
    "mean_rate_lpha_on_rows": ("L/ha", "Mean application rate along the planned stretches of the rows, L/ha"),
    "deposit_cv_on_rows": ("1", "Coefficient of variation of the rate along the planned stretches of the rows"),
    "row_rate_ratio_min": ("1", "Lowest mean rate of a row (over its planned stretch) / the asked rate"),
    "row_rate_ratio_max": ("1", "Highest mean rate of a row (over its planned stretch) / the asked rate"),
    "row_rate_error_max": ("1", "Largest |row mean rate / asked rate - 1| over the rows"),
    "dose_window_ratio_max": ("1", "Highest mean rate of a dose window (1 m by default) along a planned stretch / asked"),
    "dose_window_ratio_min": ("1", "Lowest mean rate of a dose window (1 m by default) along a planned stretch / asked"),
    "dose_faults": ("1", "Number of stretches along the rows dosed above the hot or below the gap band"),
    "row_in_band_fraction_min": ("1", "Lowest share of a row's planned stretch (0.5 m pieces) within the rate tolerance "
                                      "(±15 % by default) of the asked rate"),
    "drift_outside_fence_fraction": ("1", "Share of the emitted volume landing outside the geofence (or the field)"),
    "deposit_in_no_spray_fraction": ("1", "Share of the emitted volume landing in the world's no-spray zones (grown by "
                                          "their buffer; 0 without zones)"),
    "nominal_rate_lpha": ("L/ha", "Rate the spray phase asked for (rate_lpha, or 10 000 q / (v track width)), L/ha"),
    "spray_swath_m": ("m", "Geometric swath of the nozzles at the spray height, m"),
    "spray_track_width_m": ("m", "Track width of the flow (flow = rate x width x speed): lane spacing, or the single-pass width, m"),
    "treated_area_ha": ("ha", "Area the spray plan treats: the rows' planned stretches x their spacing, ha"),
    "spray_effective_swath_m": ("m", "Effective swath of the vehicle at the spray height and speed (overlapped CV <= 10 %), m"),
    "deposit_centroid_offset_east_m": ("m", "Deposit centroid minus the volume-weighted nozzle path centroid, east, m"),
    "deposit_centroid_offset_north_m": ("m", "Deposit centroid minus the volume-weighted nozzle path centroid, north, m"),
}


def near_polylines(xc: np.ndarray, yc: np.ndarray, lines: Sequence[Polyline], reach_m: float) -> np.ndarray:
    """Mask (ny, nx) of the grid cells (centres ``xc``, ``yc`` ascending, m) within ``reach_m`` of any segment of
    ``lines``: each segment is measured only over the cells of its bounding box grown by the reach (the same cells
    as a distance to every segment over the whole grid, at a fraction of the work)."""
    mask = np.zeros((yc.size, xc.size), dtype=bool)
    for line in lines:
        for seg in segments(line):
            ax, ay, bx, by = seg.ax, seg.ay, seg.bx, seg.by
            x0 = int(np.searchsorted(xc, min(ax, bx) - reach_m, side="left"))
            x1 = int(np.searchsorted(xc, max(ax, bx) + reach_m, side="right"))
            y0 = int(np.searchsorted(yc, min(ay, by) - reach_m, side="left"))
            y1 = int(np.searchsorted(yc, max(ay, by) + reach_m, side="right"))
            if x1 <= x0 or y1 <= y0:
                continue
            px, py = np.meshgrid(xc[x0:x1], yc[y0:y1])
            mask[y0:y1, x0:x1] |= seg.nearest(px, py)[1] <= reach_m
    return mask


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
            d, s = distance_along(gx, gy, line)
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


def _windows(rate: np.ndarray, k: int) -> np.ndarray:
    """Means of ``k`` consecutive pieces (NaN pieces count as 0: no grid there means nothing landed)."""
    r = np.nan_to_num(rate, nan=0.0)
    if r.size < k:
        return np.array([r.mean()]) if r.size else r
    c = np.concatenate([[0.0], np.cumsum(r)])
    return (c[k:] - c[:-k]) / k


def _faults(s_m: np.ndarray, win: np.ndarray, k: int, seg: float, nominal: float, bands: tuple[float, float]
            ) -> list[dict[str, Any]]:
    """Runs of windows above the hot or below the gap band: kind, from / to along the row (m), extreme ratio."""
    gap, hot = bands
    out: list[dict[str, Any]] = []
    ratio = win / nominal
    kind = np.where(ratio > hot, 1, np.where(ratio < gap, -1, 0))
    i = 0
    while i < kind.size:
        if kind[i] == 0:
            i += 1
            continue
        j = i
        while j + 1 < kind.size and kind[j + 1] == kind[i]:
            j += 1
        sel = ratio[i:j + 1]
        out.append({"kind": "hot" if kind[i] > 0 else "gap", "from_m": float(s_m[i] - 0.5 * seg),
                    "to_m": float(s_m[j + k - 1] + 0.5 * seg), "ratio": float(sel.max() if kind[i] > 0 else sel.min())})
        i = j + 1
    return out


def _row_dose(pr: dict[str, Any], nominal: float, segment_m: float, window_m: float, bands: tuple[float, float],
              tolerance: float, passes: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Fill ``pr`` (a row profile with ``planned_m``) with its dose figures; (pieces in the planned stretch, windows).
    ``passes``: the passes over each piece of a phase that repeats them (:mod:`vinecli.missions.repeat_passes`): the
    dose figures are per pass (the rate over the passes there), the returned pieces the totals."""
    s0, s1 = pr["planned_m"]
    total, s = pr["rate_lpha"], pr["s_m"]
    r = total
    if passes is not None:
        pr["passes"] = passes
        r = np.where(passes > 1, total / np.maximum(passes, 1), total)
    inside = (s >= s0 - 1e-9) & (s <= s1 + 1e-9)
    for a, b in pr.get("holes_m", []):  # the taper beside a no-spray zone: expected, not judged
        inside &= (s <= a) | (s >= b)
    seg_len = pr["seg_len_m"][inside]
    rin = r[inside]
    ok = np.nan_to_num(rin, nan=0.0) >= 0.5 * nominal if nominal > 0 else np.zeros(rin.shape, bool)
    planned = float(seg_len.sum())
    pr["covered_fraction"] = float(min(seg_len[ok].sum() / planned, 1.0)) if planned > 0 else math.nan
    idx = np.flatnonzero(np.nan_to_num(r, nan=0.0) >= 0.5 * nominal) if nominal > 0 else np.zeros(0, int)
    pr["sprayed_m"] = [float(s[idx[0]]), float(s[idx[-1]])] if idx.size else None
    vals = np.nan_to_num(rin, nan=0.0)
    pr["mean_rate_lpha"] = float(np.average(vals, weights=seg_len)) if planned > 0 else math.nan
    if passes is not None:
        pr["mean_rate_per_pass_lpha"] = pr["mean_rate_lpha"]
        pr["mean_rate_lpha"] = float(np.average(np.nan_to_num(total[inside], nan=0.0), weights=seg_len)) \
            if planned > 0 else math.nan
    near = np.abs(vals / nominal - 1.0) <= tolerance if nominal > 0 else np.zeros(vals.shape, bool)
    pr["in_band_fraction"] = float(min(seg_len[near].sum() / planned, 1.0)) if planned > 0 else math.nan
    k = max(1, int(round(window_m / segment_m)))
    win = _windows(rin, k) if rin.size else np.zeros(0)
    pr["window_ratio"] = [float(win.min() / nominal), float(win.max() / nominal)] if win.size and nominal > 0 else None
    pr["faults"] = _faults(s[inside], win, k, segment_m, nominal, bands) if win.size and nominal > 0 else []
    return np.nan_to_num(total[inside], nan=0.0), win


# parameters: the run's deposition, rows and fence, then the dose's settings with their defaults (DoseSpec's
# fields, named by the caller)
def deposition_metrics(dep: DepositionResult, rows: Sequence[Polyline], canopy_width_m: float,
                       fence: Sequence[tuple[float, float]] | None, nominal_rate_lpha: float,
                       segment_m: float = 0.5, canopy_rows: Sequence[Polyline] | None = None,
                       stretches: dict[int, tuple[float, float]] | None = None, window_m: float = 1.0,
                       bands: tuple[float, float] = (0.6, 1.3), tolerance: float = 0.15,
                       holes: dict[int, list[tuple[float, float]]] | None = None,
                       passes: list[np.ndarray] | None = None) -> tuple[dict[str, float], list[dict[str, Any]]]:
    """(metrics, per-row figures) of a :class:`~vinecli.sim.spray_deposit.DepositionResult`.

    ``rows``: the rows the mission targeted (coverage, mean rate, CV, per-row figures);
    ``canopy_rows``: every row of the field (the on-row fraction: liquid on any vine), default ``rows``;
    ``stretches``: the planned stretch of each targeted row (index into ``rows``: (start, end) m along it; rows
    missing from it were not planned); default: every row whole. ``bands``: (gap, hot) ratios of the dose faults;
    ``tolerance``: the rate band of ``row_in_band_fraction_min`` (share of a row within ±tolerance of the asked rate);
    ``holes``: stretches inside a row's planned stretch that are not judged (the taper beside a no-spray zone);
    ``passes``: per row, the passes over each piece of a phase that repeats them: its dose windows, row rates,
    coverage and in-band share are per pass (the mean rate and the CV stay the totals).
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
        band = near_polylines(xc, yc, canopy, hw)
        m["deposit_on_rows_fraction"] = _fraction(float(dep.volume_l[band].sum()), em)
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
        m["drift_outside_fence_fraction"] = _fraction(float(dep.volume_l[outside].sum() + dep.off_grid_l), em)
    else:
        m["drift_outside_fence_fraction"] = nan
    profiles = row_profiles(dep.grid, dep.volume_l, rows, hw, segment_m) if rows else []
    tot_len = cov_len = 0.0
    pieces: list[np.ndarray] = []
    windows: list[np.ndarray] = []
    row_means: list[float] = []
    n_faults = 0
    for i, pr in enumerate(profiles):
        pr["row"] = i
        planned = (stretches or {}).get(i) if stretches is not None else (0.0, pr["length_m"])
        pr["planned_m"] = [float(planned[0]), float(planned[1])] if planned is not None else None
        pr["holes_m"] = [[float(a), float(b)] for a, b in (holes or {}).get(i, [])]
        if planned is None:  # not planned (outside the fence): reported, not judged
            pr.update(covered_fraction=nan, sprayed_m=None, mean_rate_lpha=nan, window_ratio=None, faults=[],
                      in_band_fraction=nan)
            continue
        vals, win = _row_dose(pr, nominal_rate_lpha, segment_m, window_m, bands, tolerance,
                              passes[i] if passes is not None else None)
        length = planned[1] - planned[0] - sum(b - a for a, b in pr["holes_m"])
        tot_len += length
        cov_len += pr["covered_fraction"] * length if pr["covered_fraction"] == pr["covered_fraction"] else 0.0
        pieces.append(vals)
        windows.append(win)
        row_means.append(pr.get("mean_rate_per_pass_lpha", pr["mean_rate_lpha"]))
        n_faults += len(pr["faults"])
    m["row_coverage_fraction"] = _fraction(cov_len, tot_len) if tot_len > 0 else nan
    allr = np.concatenate(pieces) if pieces else np.zeros(0)
    mean = float(np.mean(allr)) if allr.size else nan
    m["mean_rate_lpha_on_rows"] = mean
    m["deposit_cv_on_rows"] = float(np.std(allr) / mean) if allr.size and mean > 0 else nan
    ok = nominal_rate_lpha > 0 and bool(row_means)
    ratios = np.asarray(row_means) / nominal_rate_lpha if ok else np.zeros(0)
    m["row_rate_ratio_min"] = float(np.nanmin(ratios)) if ratios.size else nan
    m["row_rate_ratio_max"] = float(np.nanmax(ratios)) if ratios.size else nan
    m["row_rate_error_max"] = float(np.nanmax(np.abs(ratios - 1.0))) if ratios.size else nan
    allw = np.concatenate(windows) if windows else np.zeros(0)
    m["dose_window_ratio_max"] = float(allw.max() / nominal_rate_lpha) if allw.size and nominal_rate_lpha > 0 else nan
    m["dose_window_ratio_min"] = float(allw.min() / nominal_rate_lpha) if allw.size and nominal_rate_lpha > 0 else nan
    m["dose_faults"] = float(n_faults) if ok else nan
    inband = [pr["in_band_fraction"] for pr in profiles if pr.get("planned_m")]
    m["row_in_band_fraction_min"] = float(np.nanmin(inband)) if inband and ok else nan
    return m, profiles


def no_spray_fraction(dep: DepositionResult, zones: Sequence[Sequence[tuple[float, float]]]) -> float:
    """Share of the emitted volume of ``dep`` landing in the no-spray ``zones`` (rings, ENU m; grid cells by their
    centres); 0 without zones, NaN when nothing was emitted."""
    em = float(dep.emitted_l)
    if not zones:
        return 0.0
    if em <= 0:
        return math.nan
    xc, yc = dep.grid.centres()
    gx, gy = np.meshgrid(xc, yc)
    inside = np.zeros(gx.shape, dtype=bool)
    for z in zones:
        inside |= points_in_polygon(gx, gy, z)
    return _fraction(float(dep.volume_l[inside].sum()), em)


def _fraction(part: float, whole: float) -> float:
    """``part / whole`` clipped to [0, 1] (floating-point sums can stray by 1e-16)."""
    return min(max(part / whole, 0.0), 1.0)
