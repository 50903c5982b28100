"""Row detection, part 1: grid preparation and the dominant row direction and spacing (2-D spectrum).

Grids are regular, ``z[j, i]`` at ``x[i]``, ``y[j]`` (local metres: x east, y north; heights m; NaN = no
data). Used by :func:`vinecli.rows.detect.detect_rows_grid`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from vinecli.errors import TerrainError

__all__ = ["decimate", "direction_and_spacing", "fill_and_detrend", "relief_of", "tensor_normal"]


def decimate(z: np.ndarray, x: np.ndarray, y: np.ndarray, max_cells: int
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


def fill_and_detrend(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def relief_of(z: np.ndarray, valid: np.ndarray, sigma_cells: float) -> np.ndarray:
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


def _profile_peak(s: np.ndarray, h: np.ndarray, step: float, k_guess: float, k_lo: float | None = None,
                  k_hi: float | None = None) -> tuple[float, float]:
    """(frequency of the fundamental near ``k_guess``, or of the sharpest peak in [``k_lo``, ``k_hi``], its
    amplitude) of the profile along ``s``."""
    axis, prof = _profile(s, h, step)
    pw = prof * np.hanning(prof.size)
    nfft = 1 << int(math.ceil(math.log2(prof.size * 16)))
    ps = np.abs(np.fft.rfft(pw - pw.mean(), nfft))
    fr = np.fft.rfftfreq(nfft, step)
    lo_f, hi_f = (0.8 * k_guess, 1.25 * k_guess) if k_lo is None or k_hi is None else (k_lo, k_hi)
    idx = np.flatnonzero((fr >= lo_f) & (fr <= hi_f))
    if idx.size == 0:  # the guess is beyond the profile's Nyquist frequency (a spacing of about one cell)
        return k_guess, 0.0
    k = int(idx[int(np.argmax(ps[idx]))])
    amp = float(ps[k])
    kk = float(k)
    if 0 < k < ps.size - 1:
        a, b, c = ps[k - 1], ps[k], ps[k + 1]
        den = a - 2 * b + c
        kk = k + (0.5 * (a - c) / den if den != 0 else 0.0)
    return kk * float(fr[1] - fr[0]), amp


def tensor_normal(zz: np.ndarray, valid: np.ndarray, spacing_cells: float) -> np.ndarray | None:
    """Unit normal to the rows from the structure tensor of the relief's gradients (relief: heights minus a
    Gaussian one spacing wide; gradients at an eighth of a spacing), None when its coherence is below 0.3."""
    from scipy.ndimage import binary_erosion, gaussian_filter

    r = zz - gaussian_filter(zz, spacing_cells)
    sig = max(0.7, spacing_cells / 8)
    gy = gaussian_filter(r, sig, order=(1, 0))
    gx = gaussian_filter(r, sig, order=(0, 1))
    m = binary_erosion(valid, iterations=max(1, int(math.ceil(spacing_cells))), border_value=0)
    if m.sum() < 16:
        return None
    jxx, jyy, jxy = float((gx[m] ** 2).sum()), float((gy[m] ** 2).sum()), float((gx[m] * gy[m]).sum())
    coherence = math.hypot(jxx - jyy, 2 * jxy) / max(jxx + jyy, 1e-30)
    if coherence < 0.3:
        return None
    th = 0.5 * math.atan2(2 * jxy, jxx - jyy)
    return np.array([math.cos(th), math.sin(th)])


class _RingRatio(NamedTuple):
    """Each rfft2 bin's power over the median of its ring (``ratio``) and the bins' wavenumbers (cycles/m)."""

    ratio: np.ndarray
    kx: np.ndarray
    ky: np.ndarray


def _along_normal(zz: np.ndarray, valid: np.ndarray, x: np.ndarray, y: np.ndarray, normal: np.ndarray,
                  band: tuple[float, float], spectrum: _RingRatio) -> tuple[np.ndarray, float, float]:
    """:func:`direction_and_spacing` along a given normal: the lateral profile's sharpest peak in the spacing band
    (``band``: lo, hi m; within 1.5 deg of the normal), and the spectrum's strength at that wavenumber."""
    lo, hi = band
    ratio, kx, ky = spectrum
    X, Y = np.meshgrid(x, y)
    Xv, Yv, h = X[valid], Y[valid], zz[valid]
    step = min(abs(float(x[1] - x[0])), abs(float(y[1] - y[0])))
    theta0 = math.atan2(normal[1], normal[0])
    best: tuple[float, float, float] | None = None
    for dth in np.radians(np.arange(-1.5, 1.55, 0.25)):
        nv = np.array([math.cos(theta0 + dth), math.sin(theta0 + dth)])
        f_, amp = _profile_peak(Xv * nv[0] + Yv * nv[1], h, step, 1.0 / lo, 1.0 / hi, 1.0 / lo)
        if amp > 0 and (best is None or amp > best[2]):
            best = (float(dth), f_, amp)
    if best is None:
        raise TerrainError("the spacing band is outside what the grid resolves")
    nvec = np.array([math.cos(theta0 + best[0]), math.sin(theta0 + best[0])])
    k = nvec * best[1] * (1.0 if nvec[0] >= 0 else -1.0)  # rfft2 holds kx >= 0
    j, i = _bin_of(float(k[0]), float(k[1]), float(kx[0, 1]), float(ky[1, 0]), ratio.shape[0])
    j0, i0 = max(j - 1, 0), max(i - 1, 0)
    strength = float(ratio[j0:j + 2, i0:i + 2].max()) if ratio[j0:j + 2, i0:i + 2].size else 0.0
    return nvec, 1.0 / best[1], strength


def _bin_of(kx: float, ky: float, dkx: float, dky: float, ny: int) -> tuple[int, int]:
    """(row, column) of the rfft2 bin nearest to the wavenumber (kx >= 0, ky), cycles/m."""
    return int(round(ky / dky)) % ny, int(round(kx / dkx))


def direction_and_spacing(zz: np.ndarray, valid: np.ndarray, x: np.ndarray, y: np.ndarray, lo: float, hi: float,
                          normal: np.ndarray | None = None) -> tuple[np.ndarray, float, float]:
    """(unit normal to the rows, spacing m, spectral strength) of the detrended grid ``zz``. ``normal``: the rows'
    normal the user gave (the spacing is then searched along it, within 1.5 deg, and the strength is the spectrum's
    at that wavenumber)."""
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
    # each wavenumber's power over the median power of its ring |k|: a row pattern stands out of the noise at
    # its own frequency; the red spectrum of woodland or terrain does not (it only rises towards low |k|)
    dk = max(float(kx[0, 1]), abs(float(ky[1, 0])))
    ring = np.round(kmag / dk).astype(int)
    ring_med = np.zeros(int(ring.max()) + 1)
    rb = ring[band]
    order = np.argsort(rb, kind="stable")
    vals, starts = np.unique(rb[order], return_index=True)
    for v, chunk in zip(vals, np.split(spec[band][order], starts[1:]), strict=True):
        ring_med[v] = float(np.median(chunk))
    ratio = np.where(band, spec / np.maximum(ring_med[ring], 1e-30), 0.0)
    if normal is not None:
        return _along_normal(zz, valid, x, y, np.asarray(normal, float), (lo, hi), _RingRatio(ratio, kx, ky))
    j, i = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    for m in (6, 5, 4, 3, 2):  # the peak may be a harmonic of the row profile (narrow canopies: up to the 6th): the
        # fundamental, the lowest frequency that is there
        jc, ic = _bin_of(float(kx[0, i]) / m, float(ky[j, 0]) / m, float(kx[0, 1]), float(ky[1, 0]), pad[0])
        j0, i0 = max(jc - 1, 0), max(ic - 1, 0)
        win = ratio[j0:jc + 2, i0:ic + 2]
        if win.size and band[jc, ic]:
            jj, ii = np.unravel_index(int(np.argmax(win)), win.shape)
            if win[jj, ii] >= 100.0 and spec[j0 + jj, i0 + ii] >= 0.1 * spec[j, i]:
                j, i = j0 + jj, i0 + ii
                break
    k = np.array([float(kx[0, i]), float(ky[j, 0])])
    strength = float(ratio[j, i])
    knorm = float(np.hypot(*k))
    nvec = k / knorm
    tensor = tensor_normal(zz, valid, 1.0 / knorm / min(abs(dx), abs(dy)))
    if tensor is not None:  # curved rows smear the spectral peak; the mean gradient orientation does not
        nvec = tensor if float(tensor @ nvec) >= 0 else -tensor
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
