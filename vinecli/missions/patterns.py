"""Spray patterns over vine rows, and vine-row detection from a DSM.

* :func:`boustrophedon`: rows (ENU polylines) -> passes in lawn-mower order, alternating
  direction, starting at the row end nearest a start point.
* :func:`detect_rows`: dominant row direction and spacing of a height grid from the 2-D
  spectrum of the detrended heights (peak in the band of plausible spacings, refined on a
  zero-padded 1-D profile across the rows), then row centre lines (profile maxima) clipped
  to where the grid has data -> ENU polylines.
* :func:`detect_rows_in_dsm` / :func:`detect_rows_in_world`: the same on a GeoTIFF (local
  affine CRS -> ENU about the raster centre) or on a built world's height grid.
* :func:`spray_mission`: rows -> a MissionSpec (takeoff, spray, land) to export as ``.plan``.

Directions are ENU angles in degrees from east, counter-clockwise, folded to [0, 180).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from vinecli.errors import InputError, TerrainError
from vinecli.geo import GeoOrigin
from vinecli.specs import format_validation_error
from vinecli.specs.limits import MAX_DURATION_S
from vinecli.specs.mission import LandPhase, MissionSpec, SprayPhase, TakeoffPhase

Polyline = list[tuple[float, float]]


# ---------------------------------------------------------------- boustrophedon
def row_direction(rows: Sequence[Sequence[tuple[float, float]]]) -> tuple[float, float]:
    """Unit vector of the mean row direction (rows' end-to-end vectors, sign-aligned)."""
    sx = sy = 0.0
    ref: tuple[float, float] | None = None
    for r in rows:
        dx, dy = r[-1][0] - r[0][0], r[-1][1] - r[0][1]
        if ref is None:
            ref = (dx, dy)
        elif dx * ref[0] + dy * ref[1] < 0:
            dx, dy = -dx, -dy
        sx, sy = sx + dx, sy + dy
    n = math.hypot(sx, sy)
    if n == 0:
        raise ValueError("rows have no length")
    return sx / n, sy / n


def boustrophedon(rows: Sequence[Sequence[tuple[float, float]]], start_xy: tuple[float, float] = (0.0, 0.0)
                  ) -> list[Polyline]:
    """Rows as passes in lawn-mower order: sorted across the row direction starting from the side
    nearer ``start_xy``, each pass reversed relative to the previous one; the first pass begins at
    the end of its row nearer ``start_xy``."""
    rows = [[(float(x), float(y)) for x, y in r] for r in rows if len(r) >= 2]
    if not rows:
        return []
    ux, uy = row_direction(rows)

    def offset(r: Polyline) -> float:  # position across the rows (left normal)
        cx = (r[0][0] + r[-1][0]) / 2
        cy = (r[0][1] + r[-1][1]) / 2
        return -uy * cx + ux * cy

    order = sorted(rows, key=offset)
    s_off = -uy * start_xy[0] + ux * start_xy[1]
    if abs(offset(order[-1]) - s_off) < abs(offset(order[0]) - s_off):
        order.reverse()
    first = order[0]
    forward = math.dist(first[0], start_xy) <= math.dist(first[-1], start_xy)
    legs = []
    for r in order:
        # orient each row along +u or -u, alternating
        along = (r[-1][0] - r[0][0]) * ux + (r[-1][1] - r[0][1]) * uy >= 0
        seq = r if along else r[::-1]
        if not forward:
            seq = seq[::-1]
        legs.append(seq)
        forward = not forward
    # make the first leg start at the end nearer the start point
    if math.dist(legs[0][-1], start_xy) < math.dist(legs[0][0], start_xy):
        legs = [leg[::-1] for leg in legs]
    return legs


def spray_mission(rows: Sequence[Sequence[tuple[float, float]]], *, name: str = "spray-rows", height_m: float = 2.0,
                  speed_mps: float = 1.5, flow_lps: float = 0.05, takeoff_m: float = 3.0) -> MissionSpec:
    """Takeoff, one boustrophedon spray phase over ``rows`` (explicit polylines), land.

    InputError (exit 2) for values the mission spec refuses (e.g. a speed beyond :mod:`vinecli.specs.limits`).
    """
    rows_l = [[(round(float(x), 3), round(float(y), 3)) for x, y in r] for r in rows]
    length = sum(math.dist(a, b) for r in rows_l for a, b in zip(r[:-1], r[1:], strict=True))
    try:
        return MissionSpec(
            name=name,
            description=f"boustrophedon spray over {len(rows_l)} rows at {height_m:g} m, {flow_lps:g} L/s",
            phases=[TakeoffPhase(altitude_agl_m=takeoff_m),
                    SprayPhase(rows=rows_l, height_agl_m=height_m, speed_mps=speed_mps, flow_lps=flow_lps),
                    LandPhase()],
            max_duration_s=min(MAX_DURATION_S, round(2.0 * length / speed_mps + 20.0 * len(rows_l) + 120.0, 1)),
        )
    except ValidationError as exc:
        raise InputError(f"spray mission: {format_validation_error(exc)}") from None


# ---------------------------------------------------------------- row detection
@dataclass
class RowDetection:
    """Detected rows: direction (deg ENU, [0, 180)), spacing (m), centre lines (ENU polylines)."""

    direction_deg: float
    spacing_m: float
    rows: list[Polyline] = field(default_factory=list)
    strength: float = 0.0  # spectral peak / median power in the band (>~20: clear rows)

    def to_dict(self) -> dict[str, Any]:
        return {"direction_deg": self.direction_deg, "spacing_m": self.spacing_m, "strength": self.strength,
                "rows_enu": [[list(p) for p in r] for r in self.rows]}


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


def detect_rows_grid(
    z: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    *,
    min_spacing_m: float = 0.5,
    max_spacing_m: float = 6.0,
    spacing_m: float | None = None,
    min_length_m: float | None = None,
    max_cells: int = 300_000,
) -> RowDetection:
    """Detect parallel rows in a regular height grid ``z[j, i]`` at ``x[i]``, ``y[j]`` (ENU m, uniform).

    ``spacing_m`` fixes the expected spacing (the search is then limited to ±25 % of it). Grids larger
    than ``max_cells`` are block-averaged first (NaN-aware).
    """
    z = np.asarray(z, dtype=float)
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if z.shape != (y.size, x.size) or x.size < 8 or y.size < 8:
        raise TerrainError(f"height grid must be at least 8x8 and match x, y (got {z.shape})")
    z, x, y = _decimate(z, x, y, max_cells)
    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
    zz, valid = _fill_and_detrend(z)
    ny, nx = zz.shape
    win = np.outer(np.hanning(ny), np.hanning(nx))
    pad = (int(2 ** math.ceil(math.log2(ny * 2))), int(2 ** math.ceil(math.log2(nx * 2))))
    spec = np.abs(np.fft.rfft2(zz * win, s=pad)) ** 2
    ky = np.fft.fftfreq(pad[0], d=dy)[:, None]
    kx = np.fft.rfftfreq(pad[1], d=dx)[None, :]
    kmag = np.hypot(kx, ky)
    lo, hi = (spacing_m * 0.75, spacing_m * 1.25) if spacing_m else (min_spacing_m, max_spacing_m)
    band = (kmag >= 1.0 / hi) & (kmag <= 1.0 / lo)
    if not band.any():
        raise TerrainError("the spacing band is outside what the grid resolves")
    masked = np.where(band, spec, 0.0)
    j, i = np.unravel_index(int(np.argmax(masked)), masked.shape)
    k = np.array([float(kx[0, i]), float(ky[j, 0])])
    strength = float(masked[j, i] / max(np.median(spec[band]), 1e-30))
    knorm = float(np.hypot(*k))
    nvec = k / knorm  # unit normal to the rows (ENU)
    # refine direction and spacing on 1-D profiles across the rows
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
    f = best[1]
    spacing = 1.0 / f
    s = Xv * nvec[0] + Yv * nvec[1]
    sp_axis, prof = _profile(s, h, step)
    # phase of the fundamental: row centres where cos(2π f s + φ) = 1 (ridges)
    ph = np.angle(np.sum(prof * np.exp(-2j * np.pi * f * sp_axis)))
    s0 = -ph / (2 * np.pi * f)
    smin, smax = float(s.min()), float(s.max())
    first = math.ceil((smin - s0) / spacing)
    offsets = [s0 + m * spacing for m in range(first, first + int((smax - smin) / spacing) + 2)]
    offsets = [o for o in offsets if smin + 0.25 * spacing <= o <= smax - 0.25 * spacing]
    offsets = [_local_peak(prof, sp_axis, o, spacing / 3) for o in offsets]
    u = np.array([-nvec[1], nvec[0]])  # along the rows
    direction = math.degrees(math.atan2(u[1], u[0])) % 180.0
    if direction >= 180.0 - 1e-9:
        direction = 0.0
    rows = _clip_lines(offsets, nvec, u, x, y, valid, min_length_m if min_length_m is not None else 3 * spacing,
                      zz=zz, spacing=spacing)
    return RowDetection(round(direction, 3), round(spacing, 4), rows, round(strength, 2))


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
    kk = float(idx[int(np.argmax(ps[idx]))])
    amp = float(ps[int(kk)])
    k = int(kk)
    if 0 < k < ps.size - 1:
        a, b, c = ps[k - 1], ps[k], ps[k + 1]
        den = a - 2 * b + c
        kk = k + (0.5 * (a - c) / den if den != 0 else 0.0)
    return kk * float(fr[1] - fr[0]), amp


def _local_peak(prof: np.ndarray, axis: np.ndarray, o: float, half: float) -> float:
    """The profile maximum within ``o ± half`` (parabolic refinement), or ``o`` if none."""
    idx = np.flatnonzero(np.abs(axis - o) <= half)
    if idx.size < 3:
        return o
    k = int(idx[np.argmax(prof[idx])])
    if k in (idx[0], idx[-1]):
        return o
    a, b, c = prof[k - 1], prof[k], prof[k + 1]
    den = a - 2 * b + c
    shift = 0.5 * (a - c) / den if den != 0 else 0.0
    return float(axis[k] + shift * (axis[1] - axis[0]))


def _clip_lines(offsets: Sequence[float], nvec: np.ndarray, u: np.ndarray, x: np.ndarray, y: np.ndarray,
                valid: np.ndarray, min_length: float, zz: np.ndarray | None = None, spacing: float | None = None,
                min_contrast: float = 0.3) -> list[Polyline]:
    """Each line {p: p·n = o}, sampled every half cell, kept over its longest run where the grid has
    data and (with ``zz``/``spacing``) a row is present: the ridge height over the mean of the two
    neighbouring furrows (±spacing/2), averaged over 2 m along the line, is at least
    ``min_contrast`` × the 90th percentile of that contrast over all lines."""
    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
    step = min(abs(dx), abs(dy)) / 2
    corners = np.array([[x[0], y[0]], [x[-1], y[0]], [x[0], y[-1]], [x[-1], y[-1]]])
    t_all = corners @ u
    ts = np.arange(t_all.min(), t_all.max() + step, step)

    def sample(ox: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        px = ox * nvec[0] + ts * u[0]
        py = ox * nvec[1] + ts * u[1]
        ii = np.round((px - x[0]) / dx).astype(int)
        jj = np.round((py - y[0]) / dy).astype(int)
        inside = (ii >= 0) & (ii < x.size) & (jj >= 0) & (jj < y.size)
        ok = np.zeros(ts.size, dtype=bool)
        ok[inside] = valid[jj[inside], ii[inside]]
        h = np.full(ts.size, np.nan)
        if zz is not None:
            h[inside] = zz[jj[inside], ii[inside]]
        return px, py, ok, h

    lines = []
    for o in offsets:
        px, py, ok, h = sample(o)
        contrast = None
        if zz is not None and spacing:
            _, _, ok_a, ha = sample(o - spacing / 2)
            _, _, ok_b, hb = sample(o + spacing / 2)
            c = h - 0.5 * (ha + hb)
            c = np.where(ok & ok_a & ok_b, c, np.nan)
            n = max(1, int(round(2.0 / step)))
            num = np.convolve(np.nan_to_num(c), np.ones(n), "same")
            den = np.convolve(np.isfinite(c).astype(float), np.ones(n), "same")
            contrast = np.where(den > 0, num / np.maximum(den, 1), np.nan)
        lines.append((px, py, ok, contrast))
    thr = None
    allc = [c[np.isfinite(c)] for *_, c in lines if c is not None]
    if allc and sum(a.size for a in allc):
        thr = min_contrast * float(np.percentile(np.concatenate(allc), 90))
    rows: list[Polyline] = []
    for px, py, ok, contrast in lines:
        keep = ok.copy()
        if contrast is not None and thr is not None and thr > 0:
            keep &= np.nan_to_num(contrast, nan=-np.inf) >= thr
        best = (0, -1)
        start = None
        for k, v in enumerate(np.append(keep, False)):
            if v and start is None:
                start = k
            elif not v and start is not None:
                if k - 1 - start > best[1] - best[0]:
                    best = (start, k - 1)
                start = None
        if best[1] <= best[0]:
            continue
        a, b = best
        if (ts[b] - ts[a]) < min_length:
            continue
        rows.append([(round(float(px[a]), 3), round(float(py[a]), 3)), (round(float(px[b]), 3), round(float(py[b]), 3))])
    return rows


def detect_rows_in_world(world_dir: Path | str, **kw: Any) -> tuple[RowDetection, GeoOrigin, tuple[float, float, float]]:
    """Rows in a built world's height grid -> (detection, origin, spawn ENU)."""
    from vinecli.world import load_world

    w = load_world(Path(world_dir))
    prev = _world_grid(w)
    if prev is None:
        raise TerrainError("the world has flat terrain: no rows to detect", path=world_dir)
    xg, yg, zg = prev
    return detect_rows_grid(zg, xg, yg, **kw), w.origin, tuple(w.spawn_enu)  # type: ignore[return-value]


def _world_grid(w: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    g = getattr(w.terrain, "grid", None)
    if g is None:
        return None
    p = g.preview(10**9)  # full resolution
    return np.asarray(p["x"], float), np.asarray(p["y"], float), np.asarray(p["z"], float)


def detect_rows_in_dsm(path: Path | str, *, max_cells: int = 300_000, **kw: Any) -> tuple[RowDetection, GeoOrigin]:
    """Rows in a DSM GeoTIFF. The ENU frame is centred on the raster centre (origin: its lat/lon and
    median height); CRS coordinates map to ENU by the local affine transform at the centre."""
    import rasterio
    from pyproj import CRS, Transformer

    path = Path(path)
    try:
        with rasterio.open(path) as ds:
            f = max(1, math.ceil(math.sqrt(ds.width * ds.height / max_cells)))
            out_shape = (max(8, ds.height // f), max(8, ds.width // f))
            z = ds.read(1, out_shape=out_shape, masked=True, resampling=rasterio.enums.Resampling.average)
            z = np.ma.filled(z.astype(float), np.nan)
            tr = ds.transform @ ds.transform.scale(ds.width / out_shape[1], ds.height / out_shape[0])
            crs = ds.crs
    except rasterio.errors.RasterioIOError as exc:
        raise TerrainError(f"cannot read raster: {exc}", path=path) from None
    if crs is None:
        raise TerrainError("raster has no CRS (cannot place it on the globe)", path=path)
    z[~np.isfinite(z) | (np.abs(z) > 1e6)] = np.nan
    ny, nx = z.shape
    to_ll = Transformer.from_crs(CRS.from_user_input(crs).to_2d(), "EPSG:4326", always_xy=True)
    cx, cy = tr @ (nx / 2, ny / 2)
    lon0, lat0 = to_ll.transform(cx, cy)
    origin = GeoOrigin(float(lat0), float(lon0), float(np.nanmedian(z)))
    # local affine CRS -> ENU by finite differences at the centre
    hstep = max(abs(tr.a), abs(tr.e))
    pts = [(cx, cy), (cx + hstep, cy), (cx, cy + hstep)]
    enu = []
    for px, py in pts:
        lon, lat = to_ll.transform(px, py)
        e, n, _ = origin.geodetic_to_enu(lat, lon, origin.alt)
        enu.append((e, n))
    J = np.array([[enu[1][0] - enu[0][0], enu[2][0] - enu[0][0]],
                  [enu[1][1] - enu[0][1], enu[2][1] - enu[0][1]]]) / hstep
    # pixel centres -> ENU: regular grid in ENU only if J is near a similarity; resample onto an ENU grid
    jj, ii = np.mgrid[0:ny, 0:nx]
    X = tr.c + (ii + 0.5) * tr.a + (jj + 0.5) * tr.b
    Y = tr.f + (ii + 0.5) * tr.d + (jj + 0.5) * tr.e
    E = J[0, 0] * (X - cx) + J[0, 1] * (Y - cy)
    N = J[1, 0] * (X - cx) + J[1, 1] * (Y - cy)
    res = float(np.sqrt(abs(np.linalg.det(J)) * abs(tr.a * tr.e - tr.b * tr.d)))
    xg = np.arange(E.min(), E.max() + res / 2, res)
    yg = np.arange(N.min(), N.max() + res / 2, res)
    from scipy.interpolate import griddata

    zg = griddata((E.ravel(), N.ravel()), z.ravel(), (xg[None, :], yg[:, None]), method="nearest")
    # outside the raster footprint -> NaN
    Jinv = np.linalg.inv(J)
    Xg = cx + Jinv[0, 0] * xg[None, :] + Jinv[0, 1] * yg[:, None]
    Yg = cy + Jinv[1, 0] * xg[None, :] + Jinv[1, 1] * yg[:, None]
    inv = ~tr
    col, row = inv @ (Xg, Yg)
    zg = np.where((col >= 0) & (col < nx) & (row >= 0) & (row < ny), zg, np.nan)
    return detect_rows_grid(zg, xg, yg, **kw), origin
