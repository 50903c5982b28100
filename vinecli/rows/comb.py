"""Row detection, part 2: the comb model of the row pattern, fitted strip by strip.

Coordinates: ``s`` across the rows (m, along the rows' left normal), ``t`` along them (m); ``h`` the canopy
relief (m above the ground estimated from the DSM itself). The field is cut into strips along the rows.

* The comb: rows at ``s = delta(t) + k p`` (spacing ``p``, row number ``k``). In each strip and each window
  of a few spacings across, the relief's Fourier component at ``1/p`` gives the comb's phase and the share of
  the relief variance the comb explains (``r2``: 0 for noise, ~0.5-0.9 for rows); windows with a clear comb
  make the row region, and the unwrapped phase along the strips is ``delta(t)``, the shift all rows share
  (their common curvature, and any error of the global direction).
* Each row ``k`` then gets, per strip, its own centre (the strip's mean lateral profile peaking within a third
  of a spacing of the comb's prediction: the midpoint of the peak's half-height crossings, so a flat-topped
  canopy is centred on its width) and contrast (peak minus the inter-row ground beside it).
* :func:`fit_row` fits a row's centre line through its knots robustly: a RANSAC line first (outliers beyond
  a sixth of a spacing dropped), then a cubic smoothing spline whose smoothing matches the knots' own
  noise (gentle curvature only), refitted once without the knots it misses by more than 3 sigma.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["Comb", "RowKnots", "Strips", "comb_of", "eval_row", "fit_row", "make_strips", "row_knots", "strip_profiles"]

#: a window whose comb explains less of the relief variance than this is not part of a row field
MIN_WINDOW_R2 = 0.25
#: ... or whose comb explains less than this share of its lateral profile (the relief averaged along the rows: young
#: plants with bare soil between them along a row; the no-row rasters' windows stay below 0.25 at their 90th percentile)
MIN_WINDOW_R2_PROFILE = 0.3
#: a strip whose windows explain less than this share of the relief has no comb phase of its own
MIN_PHASE_R2 = 0.1


@dataclass
class Strips:
    """Cells of the field in row coordinates: ``s`` across (m), ``t`` along (m), relief ``h`` (m)."""

    s: np.ndarray
    t: np.ndarray
    h: np.ndarray
    k: np.ndarray  # strip index of each cell
    t_centre: np.ndarray  # (K,) strip centres along the rows, m
    length: float  # strip length, m
    s0: float  # first profile bin edge, m
    bin_m: float  # profile bin width, m
    nbins: int


def make_strips(s: np.ndarray, t: np.ndarray, h: np.ndarray, length: float, bin_m: float) -> Strips:
    """Strips of about ``length`` m along the rows, lateral profile bins of ``bin_m`` m."""
    t0 = float(t.min())
    n_k = max(1, int(math.ceil((float(t.max()) - t0) / length)))
    length = (float(t.max()) - t0) / n_k if n_k > 1 else max(length, float(t.max()) - t0)
    k = np.minimum(((t - t0) / max(length, 1e-9)).astype(int), n_k - 1)
    s0 = float(s.min()) - 2.5 * bin_m  # cells of an axis-aligned grid fall on bin centres
    nbins = int(math.ceil((float(s.max()) + 2 * bin_m - s0) / bin_m)) + 1
    return Strips(s, t, h, k, t0 + (np.arange(n_k) + 0.5) * length, length, s0, bin_m, nbins)


@dataclass
class Comb:
    """The comb fitted to the strips: per strip the shared shift ``delta`` (m) and its slope ``skew``
    (ds/dt); per strip and lateral window the explained variance ``r2`` and the row-field mask ``region``
    (window edges ``w_edges``, m across); ``r2_field``: the median r2 over the windows with data."""

    spacing: float
    delta: np.ndarray
    skew: np.ndarray
    r2: np.ndarray
    region: np.ndarray
    w_edges: np.ndarray
    r2_field: float
    t_centre: np.ndarray
    r2_profile: np.ndarray | None = None

    def shift(self, t: np.ndarray) -> np.ndarray:
        """The shift all rows share (m across) at positions ``t`` along the rows: ``delta`` between the strip
        centres, held beyond the first and last."""
        return np.interp(t, self.t_centre, self.delta)

    def in_region(self, k: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Whether lateral positions ``s`` in strips ``k`` lie in the row field or within a spacing of it (the
        outer rows of a field sit in windows that are half bare ground)."""
        out = np.zeros(np.shape(s), dtype=bool)
        for ds in (-self.spacing, 0.0, self.spacing):
            w = np.clip(np.searchsorted(self.w_edges, s + ds) - 1, 0, self.region.shape[1] - 1)
            out |= self.region[k, w]
        return out


def comb_of(st: Strips, p: float, passes: int = 3) -> Comb:
    """Fit the comb (see the module docstring) to the strips' relief; later passes de-skew each strip by the
    comb's local slope, so rows that curve or run slightly off the global direction stay sharp."""
    comb = _comb_pass(st, p, np.zeros(st.t_centre.size))
    for _ in range(passes - 1):
        comb = _comb_pass(st, p, comb.skew)
    return comb


def _comb_pass(st: Strips, p: float, skew: np.ndarray) -> Comb:
    """One comb fit with the strips de-skewed by ``skew`` (ds/dt per strip)."""
    from scipy.ndimage import binary_closing, binary_opening

    n_k = st.t_centre.size
    width = 4.0 * p
    s_min, s_max = float(st.s.min()), float(st.s.max())
    n_w = max(1, int(round((s_max - s_min) / width)))
    edges = np.linspace(s_min, s_max + 1e-9, n_w + 1)
    w = np.clip(np.searchsorted(edges, st.s) - 1, 0, n_w - 1)
    idx = st.k * n_w + w
    h = st.h - _strip_means(st)  # zero mean per strip: the comb is the periodic part
    ph = np.exp(-2j * np.pi * (st.s - skew[st.k] * (st.t - st.t_centre[st.k])) / p)
    size = n_k * n_w
    cnt = np.bincount(idx, minlength=size).reshape(n_k, n_w)
    a = (np.bincount(idx, weights=h * ph.real, minlength=size)
         + 1j * np.bincount(idx, weights=h * ph.imag, minlength=size)).reshape(n_k, n_w)
    hm = np.bincount(idx, weights=h, minlength=size).reshape(n_k, n_w)
    h2 = np.bincount(idx, weights=h * h, minlength=size).reshape(n_k, n_w)
    var = h2 - hm ** 2 / np.maximum(cnt, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        r2 = np.where((cnt >= 16) & (var > 0), 2.0 * np.abs(a) ** 2 / (np.maximum(cnt, 1) * var), 0.0)
    r2 = np.clip(r2, 0.0, 1.0)
    r2p = _profile_r2(st, p, skew, edges, w, h, cnt)
    region = (r2 >= MIN_WINDOW_R2) | (r2p >= MIN_WINDOW_R2_PROFILE)
    if region.shape[0] >= 3 and region.shape[1] >= 3:  # single windows in noise out, single holes in rows closed
        region = binary_opening(binary_closing(region, np.ones((3, 1)), border_value=1), np.ones((2, 1))) & (cnt > 0)
    have = cnt >= 16
    r2_field = float(np.median(r2[have])) if have.any() else 0.0
    amp = np.where(region, a, 0.0).sum(axis=1)  # each strip's comb from its row windows only
    # a strip has a phase of its own where a good part of it shows the comb, even faintly (rows ending inside it);
    # elsewhere (past the rows' ends, a corner of the grid) its shift is interpolated from its neighbours
    per_strip = cnt.sum(axis=1)
    combed = np.where((r2 >= MIN_PHASE_R2) | (r2p >= MIN_WINDOW_R2_PROFILE), cnt, 0).sum(axis=1)
    good = (np.abs(amp) > 0) & (combed >= 0.25 * float(np.median(per_strip[per_strip > 0])))
    phase = -np.angle(amp)
    delta = np.zeros(n_k)
    if good.any():
        ks = np.flatnonzero(good)
        unwrapped = np.unwrap(phase[ks])
        delta = np.interp(np.arange(n_k), ks, unwrapped) * p / (2 * np.pi)
    skew = np.gradient(delta, st.t_centre) if n_k >= 2 else np.zeros(n_k)
    return Comb(p, delta, skew, r2, region, edges, r2_field, st.t_centre, r2p)


def _profile_r2(st: Strips, p: float, skew: np.ndarray, edges: np.ndarray, w: np.ndarray, h: np.ndarray,
                cnt: np.ndarray) -> np.ndarray:
    """Per strip and window, the share of the variance of the *lateral profile* (the relief averaged along the strip
    in bins of an eighth of a spacing) the comb explains. Averaging along the rows first takes out what the comb
    cannot model and rows do not need: young plants and the bare soil between them along a row."""
    n_k, n_w = cnt.shape
    nb = max(8, int(math.ceil((edges[1] - edges[0]) / (p / 8))))
    bin_m = (edges[1] - edges[0]) / nb
    s_eff = st.s - skew[st.k] * (st.t - st.t_centre[st.k])
    b = np.clip(((st.s - edges[w]) / bin_m).astype(int), 0, nb - 1)
    idx = (st.k * n_w + w) * nb + b
    size = n_k * n_w * nb
    c = np.bincount(idx, minlength=size).reshape(n_k, n_w, nb)
    m = np.bincount(idx, weights=h, minlength=size).reshape(n_k, n_w, nb) / np.maximum(c, 1)
    pos = np.bincount(idx, weights=s_eff, minlength=size).reshape(n_k, n_w, nb) / np.maximum(c, 1)
    have = c > 0
    nh = have.sum(axis=2)
    mean = np.where(have, m, 0.0).sum(axis=2) / np.maximum(nh, 1)
    d = np.where(have, m - mean[..., None], 0.0)
    var = (d ** 2).sum(axis=2)
    a = (d * np.exp(-2j * np.pi * pos / p)).sum(axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        r2p = np.where((nh >= nb // 2) & (cnt >= 16) & (var > 0), 2.0 * np.abs(a) ** 2 / (np.maximum(nh, 1) * var), 0.0)
    return np.clip(r2p, 0.0, 1.0)


def _strip_means(st: Strips) -> np.ndarray:
    """Each cell's strip mean relief."""
    n_k = st.t_centre.size
    tot = np.bincount(st.k, weights=st.h, minlength=n_k)
    cnt = np.bincount(st.k, minlength=n_k)
    return (tot / np.maximum(cnt, 1))[st.k]


def strip_profiles(st: Strips, skew: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(K, nbins) mean relief per strip and lateral bin, de-skewed by ``skew[k]`` (ds/dt; NaN where empty),
    and per bin the sums of (positive relief x t) and of positive relief (where along the strip the row is)."""
    from scipy.ndimage import gaussian_filter1d

    s_eff = st.s - skew[st.k] * (st.t - st.t_centre[st.k])
    b = np.clip(((s_eff - st.s0) / st.bin_m).astype(int), 0, st.nbins - 1)
    idx = st.k * st.nbins + b
    n = st.t_centre.size * st.nbins
    cnt = np.bincount(idx, minlength=n).reshape(-1, st.nbins)
    tot = np.bincount(idx, weights=st.h, minlength=n).reshape(-1, st.nbins)
    pos = np.bincount(idx, weights=s_eff, minlength=n).reshape(-1, st.nbins)
    axis = st.s0 + (np.arange(st.nbins) + 0.5) * st.bin_m
    prof = np.full(cnt.shape, np.nan)
    for k in range(cnt.shape[0]):  # bin means at the cells' mean positions, onto the regular axis
        have = cnt[k] > 0
        if have.sum() >= 2:
            lo, hi = np.flatnonzero(have)[[0, -1]]
            prof[k, lo:hi + 1] = np.interp(axis[lo:hi + 1], pos[k, have] / cnt[k, have], tot[k, have] / cnt[k, have])
    sig = max(0.5, spacing / 12 / st.bin_m)
    fin = np.isfinite(prof)
    num = gaussian_filter1d(np.where(fin, prof, 0.0), sig, axis=1, mode="nearest")
    den = gaussian_filter1d(fin.astype(float), sig, axis=1, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        smooth = np.where(fin, num / den, np.nan)
    wt = np.maximum(st.h, 0.0)
    tw = np.bincount(idx, weights=wt * st.t, minlength=n).reshape(-1, st.nbins)
    w = np.bincount(idx, weights=wt, minlength=n).reshape(-1, st.nbins)
    return smooth, tw, w


@dataclass
class RowKnots:
    """Per comb row (axis 0, row numbers ``k``) and strip (axis 1): the centre ``s`` and position ``t`` where
    the strip's profile peaks, its ``contrast`` (m; NaN where not measurable) and whether it lies in the
    row field (``inside``)."""

    k: np.ndarray
    s: np.ndarray
    t: np.ndarray
    contrast: np.ndarray
    inside: np.ndarray


def row_knots(st: Strips, comb: Comb) -> RowKnots:
    """The centre of every comb row in every strip (see :class:`RowKnots`)."""
    p = comb.spacing
    prof, tw, w = strip_profiles(st, comb.skew, p)
    axis = st.s0 + (np.arange(st.nbins) + 0.5) * st.bin_m
    k_lo = int(math.floor((float(st.s.min()) - float(comb.delta.max())) / p)) - 1
    k_hi = int(math.ceil((float(st.s.max()) - float(comb.delta.min())) / p)) + 1
    ks = np.arange(k_lo, k_hi + 1)
    n_k = st.t_centre.size
    S = np.full((ks.size, n_k), np.nan)
    T = np.full((ks.size, n_k), np.nan)
    C = np.full((ks.size, n_k), np.nan)
    reach = max(1, int(round(p / 3 / st.bin_m)))
    gap = max(1, int(round(p / 2 / st.bin_m)))
    for j in range(n_k):
        pj = prof[j]
        pred = comb.delta[j] + ks * p
        c = np.round((pred - st.s0) / st.bin_m - 0.5).astype(int)
        for r, ci in enumerate(c):
            if not 0 <= ci < pj.size:
                continue
            lo, hi = max(ci - reach, 1), min(ci + reach + 1, pj.size - 1)
            seg = pj[lo:hi]
            if seg.size < 3 or not np.isfinite(seg).all():
                continue
            i = lo + int(np.argmax(seg))
            side = np.array([pj[i - gap] if i >= gap else np.nan, pj[i + gap] if i + gap < pj.size else np.nan])
            if not np.isfinite(side).any():  # the ground beside the row: both sides, or the one with data
                continue
            s_c = _peak_centre(pj, i, float(np.nanmean(side)), gap, axis, st.bin_m)
            wsum = float(w[j, i - 1:i + 2].sum())
            t_c = float(tw[j, i - 1:i + 2].sum()) / wsum if wsum > 0 else float(st.t_centre[j])
            S[r, j] = s_c + float(comb.skew[j]) * (t_c - float(st.t_centre[j]))
            T[r, j] = t_c
            C[r, j] = float(pj[i] - np.nanmean(side))
    inside = np.zeros(S.shape, dtype=bool)
    fin = np.isfinite(S)
    jj = np.broadcast_to(np.arange(n_k), S.shape)
    inside[fin] = comb.in_region(jj[fin], S[fin])
    return RowKnots(ks, S, T, C, inside)


def _peak_centre(pj: np.ndarray, i: int, ground: float, gap: int, axis: np.ndarray, bin_m: float) -> float:
    """Lateral centre (m) of the profile's peak at bin ``i``: the midpoint of its two half-height crossings
    (halfway between the peak and the ground beside it, each within ``gap`` bins), so a flat-topped canopy
    (a wide hedge, a bed, a band of plots) is centred on its width, not on whichever bin of its top is
    highest; a peak without both crossings (the edge of the data) keeps the parabola through its top."""
    level = 0.5 * (float(pj[i]) + ground)
    edges = []
    for step in (-1, 1):
        j = i
        while 0 <= j + step < pj.size and abs(j + step - i) <= gap and np.isfinite(pj[j + step]) and pj[j + step] >= level:
            j += step
        n = j + step
        if not (0 <= n < pj.size and abs(n - i) <= gap and np.isfinite(pj[n])):
            break
        edges.append(axis[j] + (axis[n] - axis[j]) * (float(pj[j]) - level) / (float(pj[j]) - float(pj[n])))
    if len(edges) == 2:
        return float(0.5 * (edges[0] + edges[1]))
    shift = 0.0
    if 0 < i < pj.size - 1 and np.isfinite(pj[i - 1:i + 2]).all():
        a, b, cc = pj[i - 1], pj[i], pj[i + 1]
        den = a - 2 * b + cc
        shift = 0.5 * (a - cc) / den if den != 0 else 0.0
    return float(axis[i] + shift * bin_m)


def fit_row(t: np.ndarray, s: np.ndarray, p: float) -> tuple[np.ndarray, float] | None:
    """Which knots (t, s) of one row agree (a mask: a RANSAC line within a sixth of the spacing ``p``, grown
    along a gentle curve) and their noise sigma (m), for :func:`eval_row`; None when fewer than 2 agree."""
    if t.size < 2:
        return None
    keep = _ransac_line(t, s, p / 6)
    if keep.sum() < 2:
        return None
    return keep, _knot_sigma(t[keep], s[keep])


def _ransac_line(t: np.ndarray, s: np.ndarray, tol: float) -> np.ndarray:
    """Inliers of the line through the pair of knots most others agree with (deterministic: all pairs, or
    every pair of a fixed subsample for many knots)."""
    n = t.size
    if n <= 2:
        return np.ones(n, dtype=bool)
    idx = np.arange(n) if n <= 40 else np.linspace(0, n - 1, 40).round().astype(int)
    best = np.ones(n, dtype=bool)
    best_n = -1
    for a_i in range(idx.size):
        for b_i in range(a_i + 1, idx.size):
            a, b = idx[a_i], idx[b_i]
            if t[b] - t[a] < 1e-9:
                continue
            g = (s[b] - s[a]) / (t[b] - t[a])
            inl = np.abs(s - (s[a] + g * (t - t[a]))) <= tol
            cnt = int(inl.sum())
            if cnt > best_n:
                best, best_n = inl, cnt
    # a curved row: the line's inliers are one stretch; grow it with knots that continue it smoothly
    return best | _smooth_neighbours(t, s, best, tol)


def _smooth_neighbours(t: np.ndarray, s: np.ndarray, keep: np.ndarray, tol: float) -> np.ndarray:
    """Knots outside the line's inliers that continue the kept knots' local trend (the parabola through the
    three nearest kept knots) within ``tol``: the rest of a gently curved row."""
    out = keep.copy()
    order = np.argsort(t)
    for direction in (1, -1):
        seq = order if direction == 1 else order[::-1]
        for i in seq:
            if out[i]:
                continue
            near = np.flatnonzero(out)
            if near.size < 3:
                break
            nb = near[np.argsort(np.abs(t[near] - t[i]))[:3]]
            coef = np.polyfit(t[nb] - t[i], s[nb], 2)
            if abs(float(np.polyval(coef, 0.0)) - s[i]) <= tol:
                out[i] = True
    return out


def _knot_sigma(t: np.ndarray, s: np.ndarray) -> float:
    """The knots' own noise (m): robust scale of each inner knot's miss from the quadratic through its two
    neighbours on either side (a gentle curve passes them; noise does not)."""
    o = np.argsort(t)
    t, s = t[o], s[o]
    if t.size < 5:
        return 0.01
    res = []
    for i in range(2, t.size - 2):
        nb = [i - 2, i - 1, i + 1, i + 2]
        coef = np.polyfit(t[nb] - t[i], s[nb], 2)
        res.append(float(np.polyval(coef, 0.0)) - s[i])
    r = np.asarray(res)
    return max(0.005, float(1.4826 * np.median(np.abs(r - np.median(r)))) / 1.5)


def eval_row(t: np.ndarray, s: np.ndarray, sigma: float, tq: np.ndarray, p: float,
             shift: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """The centre line's lateral offset at ``tq``: a cubic smoothing spline through the knots (smoothing =
    their noise), refitted without knots beyond 3 sigma. Beyond the knots (a row ending inside a strip, whose
    contrast there is diluted by the bare ground past its end) the line follows ``shift`` (the comb's shared
    shift, :meth:`Comb.shift`) from the last fitted knot: the curvature all rows share, measured on the whole
    field; without ``shift``, straight on along the end slope."""
    from scipy.interpolate import UnivariateSpline

    o = np.argsort(t)
    t, s = t[o], s[o]
    keep = np.concatenate([[True], np.diff(t) > 1e-6])
    t, s = t[keep], s[keep]
    if t.size < 4:
        g = np.polyfit(t, s, 1) if t.size >= 2 else np.array([0.0, s[0]])
        return np.polyval(g, tq)
    spl = UnivariateSpline(t, s, k=3, s=t.size * sigma ** 2)
    res = np.abs(spl(t) - s)
    ok = res <= max(3 * sigma, p / 12)
    if 4 <= ok.sum() < t.size:
        t, s = t[ok], s[ok]
        spl = UnivariateSpline(t, s, k=3, s=t.size * sigma ** 2)
    out = spl(np.clip(tq, t[0], t[-1]))
    for sel, end in ((tq < t[0], t[0]), (tq > t[-1], t[-1])):
        if sel.any():
            e = np.array([end])
            if shift is not None:
                out[sel] = float(spl(e)[0]) + shift(tq[sel]) - float(shift(e)[0])
            else:
                out[sel] = float(spl(e)[0]) + float(spl.derivative()(e)[0]) * (tq[sel] - end)
    return out
