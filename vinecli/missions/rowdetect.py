"""Crop/vine row detection on a regular height grid (local metres: x east, y north; heights m).

The one row detector of vinecli (``world build`` with ``rows: auto``, ``plan rows`` and the run-time
detection all call :func:`detect_rows_grid`). Deterministic; steps:

1. dominant row direction and spacing from the 2-D spectrum of the plane-detrended heights (peak in
   the band of plausible spacings), refined on zero-padded 1-D profiles across the rows;
2. canopy relief = heights minus a NaN-aware Gaussian background (sigma = one spacing): slopes and
   terrain undulations drop out, rows stand out;
3. the field is cut into strips along the rows (about 1.5 spacings long); each strip's mean relief
   profile across the rows gives row peaks (:func:`scipy.signal.find_peaks`, prominence at least
   ``min_prominence`` x the field's typical row prominence);
4. peaks are linked strip to strip into rows (linear prediction, within 0.3 spacing; canopy gaps up
   to ``max_gap_m`` bridged). A second pass de-skews every strip by the local row slope, so curved
   rows stay sharp in the profiles;
5. each row's centre line follows the strip peaks (Savitzky-Golay smoothing, unbiased for curves),
   extends half a strip beyond the first and last strips where the row is seen (clipped to the grid's
   data) and is simplified to 2 cm (Douglas-Peucker).

Directions are angles in degrees from east (x), counter-clockwise, folded to [0, 180); every row
polyline runs along that direction; rows are numbered from west (rows running north-south) or from
south (rows running east-west).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vinecli.errors import TerrainError

Polyline = list[tuple[float, float]]

__all__ = ["Polyline", "RowDetection", "detect_rows_grid"]


@dataclass
class RowDetection:
    """Detected rows in the grid's frame (m): direction (deg from x/east, [0, 180)), spacing (m),
    centre lines, spectral strength (peak / median power in the spacing band; > ~20: clear rows) and a
    confidence in [0, 1] (support x regularity x strength factor, see :func:`detect_rows_grid`)."""

    direction_deg: float
    spacing_m: float
    rows: list[Polyline] = field(default_factory=list)
    strength: float = 0.0
    confidence: float = 0.0
    support: list[float] = field(default_factory=list)  # per row: fraction of its strips where it was seen

    @property
    def lengths_m(self) -> list[float]:
        """Length of each row polyline, m."""
        return [sum(math.dist(a, b) for a, b in zip(r[:-1], r[1:], strict=True)) for r in self.rows]

    def summary(self) -> str:
        """One line: count, spacing, orientation (ENU angle and compass bearing), confidence."""
        bearing = (90.0 - self.direction_deg) % 180.0
        total = sum(self.lengths_m)
        return (f"{len(self.rows)} rows, spacing {self.spacing_m:.3f} m, direction {self.direction_deg:.1f} deg from "
                f"east (bearing {bearing:.1f}/{bearing + 180:.1f} deg), {total:.1f} m of rows, "
                f"confidence {self.confidence:.2f}")

    def to_dict(self) -> dict[str, Any]:
        """JSON form (``rows_enu``: polylines as lists of [x, y])."""
        return {"count": len(self.rows), "direction_deg": self.direction_deg, "spacing_m": self.spacing_m,
                "strength": self.strength, "confidence": self.confidence,
                "lengths_m": [round(v, 3) for v in self.lengths_m], "support": self.support,
                "rows_enu": [[list(p) for p in r] for r in self.rows]}


# ---------------------------------------------------------------- grid preparation
def _decimate(z: np.ndarray, x: np.ndarray, y: np.ndarray, max_cells: int
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Block means (NaN-aware) by an integer factor so that the grid has at most ``max_cells`` cells."""
    f = math.ceil(math.sqrt(z.size / max_cells)) if z.size > max_cells else 1
    if f <= 1:
        return z, x, y
    ny, nx = (z.shape[0] // f) * f, (z.shape[1] // f) * f
    blocks = z[:ny, :nx].reshape(ny // f, f, nx // f, f)
    with np.errstate(invalid="ignore"):
        cnt = np.isfinite(blocks).sum(axis=(1, 3))
        zs = np.where(cnt > 0, np.nansum(blocks, axis=(1, 3)) / np.maximum(cnt, 1), np.nan)
    return zs, x[:nx].reshape(-1, f).mean(axis=1), y[:ny].reshape(-1, f).mean(axis=1)


def _fill_and_detrend(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Heights minus their least-squares plane (0 where no data) and the data mask."""
    valid = np.isfinite(z)
    if valid.sum() < 16:
        raise TerrainError("too few valid heights to detect rows")
    zz = np.where(valid, z, np.nanmedian(z))
    ny, nx = zz.shape
    jj, ii = np.mgrid[0:ny, 0:nx]
    A = np.column_stack([np.ones(valid.sum()), ii[valid], jj[valid]])
    coef, *_ = np.linalg.lstsq(A, zz[valid], rcond=None)
    zz = zz - (coef[0] + coef[1] * ii + coef[2] * jj)
    zz[~valid] = 0.0
    return zz, valid


def _relief(z: np.ndarray, valid: np.ndarray, sigma_cells: float) -> np.ndarray:
    """Heights above a NaN-aware Gaussian background (normalised convolution), m; NaN where no data."""
    from scipy.ndimage import gaussian_filter

    w = valid.astype(float)
    num = gaussian_filter(np.where(valid, z, 0.0), sigma_cells, mode="constant")
    den = gaussian_filter(w, sigma_cells, mode="constant")
    with np.errstate(invalid="ignore", divide="ignore"):
        bg = num / den
    return np.where(valid, z - bg, np.nan)


# ---------------------------------------------------------------- direction and spacing (spectrum)
def _profile(s: np.ndarray, h: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean height in bins of ``step`` along ``s``, interpolated onto a regular axis (bin mean positions)."""
    bins = np.floor((s - s.min()) / step).astype(int)
    cnt = np.bincount(bins)
    have = cnt > 0
    prof = np.bincount(bins, weights=h)[have] / cnt[have]
    pos = np.bincount(bins, weights=s)[have] / cnt[have]
    axis = s.min() + (np.arange(cnt.size) + 0.5) * step
    return axis, np.interp(axis, pos, prof)


def _profile_peak(s: np.ndarray, h: np.ndarray, step: float, k_guess: float) -> tuple[float, float]:
    """(frequency of the fundamental near ``k_guess``, its amplitude) of the profile along ``s``."""
    axis, prof = _profile(s, h, step)
    pw = prof * np.hanning(prof.size)
    nfft = 1 << int(math.ceil(math.log2(prof.size * 16)))
    ps = np.abs(np.fft.rfft(pw - pw.mean(), nfft))
    fr = np.fft.rfftfreq(nfft, step)
    idx = np.flatnonzero((fr >= 0.8 * k_guess) & (fr <= 1.25 * k_guess))
    k = int(idx[int(np.argmax(ps[idx]))])
    amp = float(ps[k])
    kk = float(k)
    if 0 < k < ps.size - 1:
        a, b, c = ps[k - 1], ps[k], ps[k + 1]
        den = a - 2 * b + c
        kk = k + (0.5 * (a - c) / den if den != 0 else 0.0)
    return kk * float(fr[1] - fr[0]), amp


def _direction_and_spacing(zz: np.ndarray, valid: np.ndarray, x: np.ndarray, y: np.ndarray, lo: float, hi: float
                           ) -> tuple[np.ndarray, float, float]:
    """(unit normal to the rows, spacing m, spectral strength) of the detrended grid ``zz``."""
    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
    ny, nx = zz.shape
    win = np.outer(np.hanning(ny), np.hanning(nx))
    pad = (int(2 ** math.ceil(math.log2(ny * 2))), int(2 ** math.ceil(math.log2(nx * 2))))
    spec = np.abs(np.fft.rfft2(zz * win, s=pad)) ** 2
    ky = np.fft.fftfreq(pad[0], d=dy)[:, None]
    kx = np.fft.rfftfreq(pad[1], d=dx)[None, :]
    kmag = np.hypot(kx, ky)
    band = (kmag >= 1.0 / hi) & (kmag <= 1.0 / lo)
    if not band.any():
        raise TerrainError("the spacing band is outside what the grid resolves")
    masked = np.where(band, spec, 0.0)
    j, i = np.unravel_index(int(np.argmax(masked)), masked.shape)
    k = np.array([float(kx[0, i]), float(ky[j, 0])])
    strength = float(masked[j, i] / max(np.median(spec[band]), 1e-30))
    knorm = float(np.hypot(*k))
    nvec = k / knorm
    X, Y = np.meshgrid(x, y)
    Xv, Yv, h = X[valid], Y[valid], zz[valid]
    step = min(abs(dx), abs(dy))
    theta0 = math.atan2(nvec[1], nvec[0])
    best: tuple[float, float, float] | None = None
    for dth in np.radians(np.arange(-1.5, 1.55, 0.1)):
        nv = np.array([math.cos(theta0 + dth), math.sin(theta0 + dth)])
        f_, amp = _profile_peak(Xv * nv[0] + Yv * nv[1], h, step, knorm)
        if best is None or amp > best[2]:
            best = (float(dth), f_, amp)
    assert best is not None
    nvec = np.array([math.cos(theta0 + best[0]), math.sin(theta0 + best[0])])
    return nvec, 1.0 / best[1], strength


def _gradients(relief: np.ndarray, valid: np.ndarray, sigma_cells: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gradients (per cell) of the lightly smoothed relief and the mask of cells where they are meaningful."""
    from scipy.ndimage import binary_erosion, gaussian_filter

    r = gaussian_filter(np.where(valid, relief, 0.0), max(sigma_cells, 0.5))
    gy, gx = np.gradient(r)
    m = binary_erosion(valid, iterations=max(1, int(math.ceil(2 * sigma_cells))), border_value=0)
    return gx, gy, m


# ---------------------------------------------------------------- strips, peaks, tracking
@dataclass
class _Strips:
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


def _strips(s: np.ndarray, t: np.ndarray, h: np.ndarray, length: float, bin_m: float) -> _Strips:
    t0 = float(t.min())
    n_k = max(1, int(math.ceil((float(t.max()) - t0) / length)))
    length = (float(t.max()) - t0) / n_k if n_k > 1 else max(length, float(t.max()) - t0)
    k = np.minimum(((t - t0) / max(length, 1e-9)).astype(int), n_k - 1)
    s0 = float(s.min()) - 2.5 * bin_m  # cells of an axis-aligned grid fall on bin centres
    nbins = int(math.ceil((float(s.max()) + 2 * bin_m - s0) / bin_m)) + 1
    return _Strips(s, t, h, k, t0 + (np.arange(n_k) + 0.5) * length, length, s0, bin_m, nbins)


def _profiles(st: _Strips, skew: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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


def _peaks(profs: tuple[np.ndarray, np.ndarray, np.ndarray], st: _Strips, skew: np.ndarray, spacing: float,
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


def _track(peaks: list[list[tuple[float, float]]], spacing: float, gap_strips: int, skew: np.ndarray
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


def _skew(chains: list[list[tuple[int, float, float]]], st: _Strips) -> np.ndarray:
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


def _tensor_skew(gx: np.ndarray, gy: np.ndarray, m: np.ndarray, st: _Strips, n: np.ndarray, u: np.ndarray
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


# ---------------------------------------------------------------- rows as polylines
def _line(t: np.ndarray, s: np.ndarray, extend: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """(t, s) every ``step`` m through knots (t, s): a cubic spline, extended ``extend`` m at both ends
    straight on along the end slope of a quadratic fit of the last five knots (trimmed later)."""
    from scipy.interpolate import CubicSpline

    order = np.argsort(t)
    t, s = t[order], s[order]
    keep = np.concatenate([[True], np.diff(t) > 1e-6])
    t, s = t[keep], s[keep]
    tt = np.arange(t[0] - extend, t[-1] + extend + step / 2, step)
    if s.size >= 4:
        cs = CubicSpline(t, s)
        inner = np.clip(tt, t[0], t[-1])
        deg = 2 if s.size >= 5 else 1
        g0 = np.polyval(np.polyder(np.polyfit(t[:5], s[:5], deg)), t[0])
        g1 = np.polyval(np.polyder(np.polyfit(t[-5:], s[-5:], deg)), t[-1])
        return tt, cs(inner) + np.where(tt < t[0], g0, g1) * (tt - inner)
    g = np.polyfit(t, s, 1) if s.size >= 2 else np.array([0.0, s[0]])  # two or three knots: a straight line
    return tt, np.polyval(g, tt)


@dataclass
class _Cells:
    """Field cells sorted along the rows: ``t`` (m, ascending), ``s`` (m), relief ``h`` (m)."""

    t: np.ndarray
    s: np.ndarray
    h: np.ndarray


def _end_knot(cells: _Cells, tl: np.ndarray, sl: np.ndarray, t0: float, t1: float, spacing: float
              ) -> tuple[float, float] | None:
    """A knot for a row end beyond the last strip peak: relief-weighted centroid of the cells within
    ``[t0, t1]`` and half a spacing of the line (tl, sl)."""
    i0, i1 = np.searchsorted(cells.t, [min(t0, t1), max(t0, t1)])
    t, s, h = cells.t[i0:i1], cells.s[i0:i1], cells.h[i0:i1]
    if t.size == 0:
        return None
    d = s - np.interp(t, tl, sl)
    w = np.where(np.abs(d) < spacing / 2, np.maximum(h, 0.0), 0.0) ** 2
    if w.sum() <= 0:
        return None
    tm = float((w * t).sum() / w.sum())
    return tm, float(np.interp(tm, tl, sl) + (w * d).sum() / w.sum())


def _row_line(c: list[tuple[int, float, float]], cells: _Cells, st: _Strips, to_xy: Any, relief: np.ndarray,
              x: np.ndarray, y: np.ndarray, spacing: float, step: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Centre line (t, s) of a chain of strip peaks, ends where the row ends; an end more than a quarter
    strip beyond the last peak gets one more knot from the cells there (partial strips at the row ends)."""
    kt = np.array([q[1] for q in c])
    ks = np.array([q[2] for q in c])
    tl, sl = _line(kt, ks, st.length, step)
    trimmed = _trim_ends(tl, sl, to_xy, relief, x, y, spacing)
    if trimmed is None:
        return None
    ta, tb = float(trimmed[0][0]), float(trimmed[0][-1])
    extra = []
    if kt.min() - ta > st.length / 4:
        extra.append(_end_knot(cells, tl, sl, ta, kt.min() - st.length / 4, spacing))
    if tb - kt.max() > st.length / 4:
        extra.append(_end_knot(cells, tl, sl, kt.max() + st.length / 4, tb, spacing))
    extra = [e for e in extra if e is not None]
    if extra:
        kt = np.concatenate([kt, [e[0] for e in extra]])
        ks = np.concatenate([ks, [e[1] for e in extra]])
        tl, sl = _line(kt, ks, st.length, step)
    keep = (tl >= ta - step / 2) & (tl <= tb + step / 2)
    return tl[keep], sl[keep]


def _trim_ends(t: np.ndarray, s: np.ndarray, to_xy: Any, relief: np.ndarray, x: np.ndarray, y: np.ndarray,
               spacing: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Trim the line's ends to where the row is: the grid has data on the line and 0.3 spacing either side
    of it (a row cut lengthwise by the data's edge is not centred), and the relief along the line, averaged
    over half a spacing, is at least half its median over the line. None if nothing is left."""
    from scipy.ndimage import uniform_filter1d

    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])

    def sample(ds: float) -> np.ndarray:
        px, py = to_xy(s + ds, t)
        ii = np.round((px - x[0]) / dx).astype(int)
        jj = np.round((py - y[0]) / dy).astype(int)
        inside = (ii >= 0) & (ii < x.size) & (jj >= 0) & (jj < y.size)
        out = np.full(t.size, np.nan)
        out[inside] = relief[jj[inside], ii[inside]]
        return out

    h = sample(0.0)
    ok = np.isfinite(h) & np.isfinite(sample(-0.3 * spacing)) & np.isfinite(sample(0.3 * spacing))
    if ok.sum() < 2:
        return None
    n = max(1, int(round(0.5 * spacing / max(float(t[1] - t[0]), 1e-9))))
    hs = uniform_filter1d(np.where(ok, h, 0.0), n) / np.maximum(uniform_filter1d(ok.astype(float), n), 1e-9)
    thr = 0.5 * float(np.median(hs[ok]))
    present = ok & (hs >= thr) if thr > 0 else ok
    if not present.any():
        return None
    a, b = int(np.argmax(present)), int(len(present) - 1 - np.argmax(present[::-1]))
    return t[a:b + 1], s[a:b + 1]


def _simplify(pts: np.ndarray, tol: float) -> np.ndarray:
    """Douglas-Peucker simplification of an (n, 2) polyline (shapely)."""
    from shapely.geometry import LineString

    if len(pts) <= 2:
        return pts
    return np.asarray(LineString(pts).simplify(tol, preserve_topology=False).coords)


def detect_rows_grid(
    z: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    *,
    min_spacing_m: float = 0.5,
    max_spacing_m: float = 6.0,
    spacing_m: float | None = None,
    min_length_m: float | None = None,
    max_gap_m: float = 4.0,
    min_prominence: float = 0.3,
    max_cells: int = 300_000,
) -> RowDetection:
    """Detect rows in a regular height grid ``z[j, i]`` at ``x[i]``, ``y[j]`` (m, uniform; NaN = no data).

    ``spacing_m`` fixes the expected spacing (searched within ±25 %). Rows shorter than ``min_length_m``
    (default: 3 spacings or two strips) are dropped; gaps in a row up to ``max_gap_m`` are bridged. Grids
    larger than ``max_cells`` are block-averaged first. ``confidence`` = support (length-weighted fraction
    of strips where each row was seen) x regularity (1 - 2 x mean deviation of neighbour distances from a
    whole number of spacings) x min(1, log10(strength) / 4) (clear rows: strength > 10^4).
    """
    z = np.asarray(z, dtype=float)
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if z.shape != (y.size, x.size) or x.size < 8 or y.size < 8:
        raise TerrainError(f"height grid must be at least 8x8 and match x, y (got {z.shape})")
    z, x, y = _decimate(z, x, y, max_cells)
    zz, valid = _fill_and_detrend(z)
    lo, hi = (spacing_m * 0.75, spacing_m * 1.25) if spacing_m else (min_spacing_m, max_spacing_m)
    nvec, spacing, strength = _direction_and_spacing(zz, valid, x, y, lo, hi)
    cell = min(abs(float(x[1] - x[0])), abs(float(y[1] - y[0])))
    relief = _relief(np.where(valid, z, np.nan), valid, spacing / cell)
    gx, gy, gmask = _gradients(relief, valid, spacing / 6 / cell)
    u = np.array([-nvec[1], nvec[0]])
    if math.atan2(u[1], u[0]) < -1e-9 or math.atan2(u[1], u[0]) >= math.pi - 1e-9:
        u = -u
    n = np.array([-u[1], u[0]])  # left normal of u
    direction = math.degrees(math.atan2(u[1], u[0])) % 180.0
    X, Y = np.meshgrid(x, y)
    h = relief[valid]
    s = X[valid] * n[0] + Y[valid] * n[1]
    t = X[valid] * u[0] + Y[valid] * u[1]
    st = _strips(s, t, h, max(1.5 * spacing, 4 * cell), min(cell, spacing / 8))
    gap_strips = int(math.floor(max_gap_m / st.length))
    skew = _tensor_skew(gx[valid], gy[valid], gmask[valid], st, n, u)
    for _ in range(3):  # later passes: strips de-skewed along the local row slope
        peaks = _peaks(_profiles(st, skew, spacing), st, skew, spacing, min_prominence)
        chains = _track(peaks, spacing, gap_strips, skew)
        skew = _skew(chains, st)
    min_len = min_length_m if min_length_m is not None else max(3 * spacing, 2 * st.length)

    def to_xy(ss: np.ndarray, tt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return ss * n[0] + tt * u[0], ss * n[1] + tt * u[1]

    order = np.argsort(t, kind="stable")
    cells = _Cells(t[order], s[order], h[order])
    found: list[tuple[float, Polyline, float, np.ndarray, np.ndarray]] = []
    for c in chains:
        if len(c) < 2:
            continue
        line_ts = _row_line(c, cells, st, to_xy, relief, x, y, spacing, max(cell, 0.05))
        if line_ts is None or line_ts[0][-1] - line_ts[0][0] < min_len:
            continue
        tl, sl = line_ts
        px, py = to_xy(sl, tl)
        pts = _simplify(np.column_stack([px, py]), 0.02)
        line = [(round(float(a), 3), round(float(b), 3)) for a, b in pts]
        support = len(c) / (c[-1][0] - c[0][0] + 1)
        found.append((float(np.mean(sl)), line, support, tl, sl))
    order_sign = 1.0 if n[0] + n[1] >= 0 else -1.0  # number rows from west / south
    found.sort(key=lambda f: order_sign * f[0])
    rows = [f[1] for f in found]
    if rows:  # the rows' mean direction (length-weighted end-to-end, doubled angles): curved rows' mean
        ends = np.array([[r[-1][0] - r[0][0], r[-1][1] - r[0][1]] for r in rows])
        ang = np.arctan2(ends[:, 1], ends[:, 0])
        ln = np.hypot(ends[:, 0], ends[:, 1])
        direction = math.degrees(0.5 * math.atan2(float((ln * np.sin(2 * ang)).sum()),
                                                  float((ln * np.cos(2 * ang)).sum()))) % 180.0
    det = RowDetection(round(direction, 3), round(spacing, 4), rows, round(strength, 2))
    det.support = [round(f[2], 3) for f in found]
    det.confidence = _confidence(found, spacing, strength, det.lengths_m)
    return det


def _confidence(found: list[tuple[float, Polyline, float, np.ndarray, np.ndarray]], spacing: float, strength: float,
                lengths: list[float]) -> float:
    """Support x regularity x strength factor, in [0, 1] (see :func:`detect_rows_grid`)."""
    if not found:
        return 0.0
    total = sum(lengths) or 1.0
    support = sum(f[2] * ln for f, ln in zip(found, lengths, strict=True)) / total
    devs = []
    for (_, _, _, ta, sa), (_, _, _, tb, sb) in zip(found[:-1], found[1:], strict=True):
        lo_t, hi_t = max(ta[0], tb[0]), min(ta[-1], tb[-1])
        tm = (lo_t + hi_t) / 2 if hi_t > lo_t else (ta[0] + ta[-1]) / 2
        d = abs(float(np.interp(tm, tb, sb) - np.interp(tm, ta, sa))) / spacing
        devs.append(abs(d - round(d)) if round(d) >= 1 else 0.5)
    regularity = 1.0 - 2.0 * float(np.mean(devs)) if devs else 0.5
    strength_f = min(1.0, math.log10(max(strength, 1.0)) / 4.0)
    return round(max(0.0, support * regularity * strength_f), 3)
