"""Row detection, part 2: strips along the rows, their lateral relief profiles, row peaks, and peaks linked
strip to strip into chains (``s``: across the rows, m; ``t``: along them, m). Used by
:func:`vinecli.rows.detect.detect_rows_grid`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Strips", "chain_skew", "make_strips", "strip_peaks", "strip_profiles", "tensor_skew", "track_peaks"]


@dataclass
class Strips:
    """Cells of the field in row coordinates: ``s`` across (m, along the normal), ``t`` along (m)."""

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
    t0 = float(t.min())
    n_k = max(1, int(math.ceil((float(t.max()) - t0) / length)))
    length = (float(t.max()) - t0) / n_k if n_k > 1 else max(length, float(t.max()) - t0)
    k = np.minimum(((t - t0) / max(length, 1e-9)).astype(int), n_k - 1)
    s0 = float(s.min()) - 2.5 * bin_m  # cells of an axis-aligned grid fall on bin centres
    nbins = int(math.ceil((float(s.max()) + 2 * bin_m - s0) / bin_m)) + 1
    return Strips(s, t, h, k, t0 + (np.arange(n_k) + 0.5) * length, length, s0, bin_m, nbins)


def strip_profiles(st: Strips, skew: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(K, nbins) mean relief per strip and lateral bin, de-skewed by ``skew[k]`` (ds/dt; 0 where empty),
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
    prof = np.zeros(cnt.shape)
    for k in range(cnt.shape[0]):  # bin means at the cells' mean positions, onto the regular axis
        have = cnt[k] > 0
        if have.sum() >= 2:
            prof[k] = np.interp(axis, pos[k, have] / cnt[k, have], tot[k, have] / cnt[k, have], left=0.0, right=0.0)
    wt = np.maximum(st.h, 0.0)
    tw = np.bincount(idx, weights=wt * st.t, minlength=n).reshape(-1, st.nbins)
    w = np.bincount(idx, weights=wt, minlength=n).reshape(-1, st.nbins)
    return gaussian_filter1d(prof, max(0.5, spacing / 12 / st.bin_m), axis=1, mode="nearest"), tw, w


def strip_peaks(profs: tuple[np.ndarray, np.ndarray, np.ndarray], st: Strips, skew: np.ndarray, spacing: float,
           min_prominence: float) -> list[list[tuple[float, float]]]:
    """Per strip: [(t, s) of the peak] with prominence >= min_prominence x the field's 90th percentile; t is
    where along the strip the row's relief is (a row ending inside the strip), s the row's offset there."""
    prof, tw, w = profs
    from scipy.signal import find_peaks

    dist = max(1, int(0.6 * spacing / st.bin_m))
    raw: list[tuple[np.ndarray, np.ndarray]] = []
    for p in prof:
        idx, props = find_peaks(p, distance=dist, prominence=0.0)
        raw.append((idx, props["prominences"]))
    allp = np.concatenate([pr for _, pr in raw]) if raw else np.array([])
    if allp.size == 0:
        return [[] for _ in raw]
    thr = min_prominence * float(np.percentile(allp, 90))
    out: list[list[tuple[float, float]]] = []
    for k, (p, (idx, pr)) in enumerate(zip(prof, raw, strict=True)):
        row = []
        for i, prom in zip(idx, pr, strict=True):
            if prom < thr or prom <= 0:
                continue
            shift = 0.0
            if 0 < i < p.size - 1:
                a, b, c = p[i - 1], p[i], p[i + 1]
                den = a - 2 * b + c
                shift = 0.5 * (a - c) / den if den != 0 else 0.0
            s_c = st.s0 + (i + 0.5 + shift) * st.bin_m  # offset at the strip centre (de-skewed profile)
            lo, hi = max(0, i - 1), min(p.size, i + 2)
            wsum = float(w[k, lo:hi].sum())
            t = float(tw[k, lo:hi].sum()) / wsum if wsum > 0 else float(st.t_centre[k])
            row.append((t, s_c + float(skew[k]) * (t - float(st.t_centre[k]))))
        out.append(row)
    return out


def track_peaks(peaks: list[list[tuple[float, float]]], spacing: float, gap_strips: int, skew: np.ndarray
           ) -> list[list[tuple[int, float, float]]]:
    """Link peaks strip to strip into chains [(strip, t, s)]: each chain's next position is predicted along
    the local row slope ``skew`` (ds/dt per strip), nearest first within 0.3 spacing; a chain stays open
    across up to ``gap_strips`` strips without a peak."""
    chains: list[list[tuple[int, float, float]]] = []
    tol = 0.3 * spacing
    for k, pk in enumerate(peaks):
        active = [c for c in chains if k - c[-1][0] <= gap_strips + 1]
        pairs = []
        for ci, c in enumerate(active):
            kl, tl, sl = c[-1]
            for pi, (t, s) in enumerate(pk):
                d = abs(s - (sl + 0.5 * (skew[kl] + skew[k]) * (t - tl)))
                if d <= tol:
                    pairs.append((d, ci, pi))
        pairs.sort()
        used_c: set[int] = set()
        used_p: set[int] = set()
        for _, ci, pi in pairs:
            if ci in used_c or pi in used_p:
                continue
            used_c.add(ci)
            used_p.add(pi)
            active[ci].append((k, *pk[pi]))
        for pi, p in enumerate(pk):
            if pi not in used_p:
                chains.append([(k, *p)])
    return chains


def chain_skew(chains: list[list[tuple[int, float, float]]], st: Strips) -> np.ndarray:
    """Local row slope ds/dt per strip: median over the chains present there (interpolated elsewhere)."""
    n_k = st.t_centre.size
    per: list[list[float]] = [[] for _ in range(n_k)]
    for c in chains:
        if len(c) < 3:
            continue
        t = np.array([q[1] for q in c])
        s = np.array([q[2] for q in c])
        if np.any(np.diff(t) <= 1e-6):
            continue
        g = np.gradient(s, t)
        for (k, *_), gk in zip(c, g, strict=True):
            per[k].append(float(gk))
    have = np.array([bool(p) for p in per])
    if not have.any():
        return np.zeros(n_k)
    med = np.array([float(np.median(p)) if p else 0.0 for p in per])
    return np.interp(np.arange(n_k), np.flatnonzero(have), med[have])


def tensor_skew(gx: np.ndarray, gy: np.ndarray, m: np.ndarray, st: Strips, n: np.ndarray, u: np.ndarray
                 ) -> np.ndarray:
    """First guess of the local row slope ds/dt per strip, from each strip's structure tensor."""
    k = st.k[m]
    size = st.t_centre.size
    jxx = np.bincount(k, weights=gx[m] ** 2, minlength=size)
    jyy = np.bincount(k, weights=gy[m] ** 2, minlength=size)
    jxy = np.bincount(k, weights=gx[m] * gy[m], minlength=size)
    th = 0.5 * np.arctan2(2 * jxy, jxx - jyy)
    nk = np.column_stack([np.cos(th), np.sin(th)])
    uk = np.column_stack([-nk[:, 1], nk[:, 0]])
    along = uk @ u
    uk[along < 0] *= -1
    skew = (uk @ n) / np.maximum(np.abs(uk @ u), 0.5)
    return np.where(jxx + jyy > 0, skew, 0.0)


