"""The deposition grid: a regular ENU raster that collects landed spray volume exactly.

Cell (iy, ix) covers ``x0 + [ix, ix+1) · cell`` east and ``y0 + [iy, iy+1) · cell`` north (row 0
south). Parcels are spread over the four nearest cell centres (cloud-in-cell, weights sum to 1);
a parcel whose stencil leaves the grid counts entirely as off-grid, so
``emitted = on_grid + off_grid`` holds to floating-point rounding.

:func:`rasterise_discs` spreads each parcel uniformly over a disc (the spray cone's footprint):
parcels are splatted onto a padded grid per footprint-radius bin and convolved (FFT) with the
normalised disc; what the convolution puts outside the grid is counted as off-grid.

Memory is bounded by two cell budgets (:func:`grid_for`): the grid itself, and the padded domain the
disc convolution works on, which grows with the largest footprint (a spray height of 400 m spreads a
parcel over a disc of ~340 m). When either would be exceeded the cell doubles, so the peak stays near
:data:`FFT_BYTES_PER_CELL` × ``max_fft_cells`` at any height and field size.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["GridSpec", "disc_kernel", "fft_cells", "grid_for", "flat_height", "rasterise", "rasterise_discs"]

HeightFn = Callable[[np.ndarray, np.ndarray], np.ndarray]

#: spacing of the log-spaced footprint radii :func:`rasterise_discs` convolves with (relative)
REL_BIN = 0.1
#: peak bytes :func:`rasterise_discs` holds per cell of its padded FFT domain (measured 26-43 B, with margin)
FFT_BYTES_PER_CELL = 48


@dataclass(frozen=True)
class GridSpec:
    """Grid geometry: south-west corner (x0, y0) m ENU, square cell (m), nx columns, ny rows."""

    x0: float
    y0: float
    cell: float
    nx: int
    ny: int

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax), m ENU."""
        return (self.x0, self.y0, self.x0 + self.nx * self.cell, self.y0 + self.ny * self.cell)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell-centre coordinates: x (nx,), y (ny,), m ENU."""
        return (self.x0 + (np.arange(self.nx) + 0.5) * self.cell, self.y0 + (np.arange(self.ny) + 0.5) * self.cell)

    def to_dict(self) -> dict[str, float | int]:
        return {"x0_m": self.x0, "y0_m": self.y0, "cell_m": self.cell, "nx": self.nx, "ny": self.ny}


def kernel_half_width(footprint_m: float, cell: float, rel_bin: float = REL_BIN) -> int:
    """Half width (cells) of the largest disc kernel :func:`rasterise_discs` builds for footprints up to
    ``footprint_m`` (m) on cells of ``cell`` m: radii are rounded up to the next log-spaced node."""
    return int(math.ceil(max(footprint_m, 0.0) / cell * math.exp(rel_bin))) + 1


def fft_cells(nx: int, ny: int, footprint_m: float, cell: float) -> int:
    """Upper bound of the padded FFT domain (cells) :func:`rasterise_discs` uses on an ``nx`` × ``ny`` grid
    for footprints up to ``footprint_m`` (m): the parcels' window (at most the grid + k each side) + k
    padding each side, rounded up to a fast FFT length."""
    k = kernel_half_width(footprint_m, cell)
    return _fft_len(nx + 4 * k) * _fft_len(ny + 4 * k)


def grid_for(points_xy: np.ndarray, extra_xy: Sequence[tuple[float, float]], terrain_bounds: tuple[float, float, float, float],
             cell_m: float, margin_m: float, max_cells: int, *, footprint_m: float = 0.0,
             max_fft_cells: int | None = None) -> GridSpec:
    """Grid over ``points_xy`` (N, 2) and ``extra_xy`` (e.g. row vertices) grown by ``margin_m``, inside the terrain.

    Snapped to multiples of ``cell_m`` (m); a larger cell (doubling) is used only when the area would
    exceed ``max_cells`` or, with ``max_fft_cells``, when the padded domain the disc convolution needs for
    footprints up to ``footprint_m`` (m, the largest cone radius on the ground) would exceed it.
    """
    pts = np.asarray(points_xy, dtype=np.float64).reshape(-1, 2)
    if len(extra_xy):
        pts = np.vstack([pts, np.asarray(extra_xy, dtype=np.float64).reshape(-1, 2)])
    if pts.size == 0:
        pts = np.zeros((1, 2))
    txmin, tymin, txmax, tymax = terrain_bounds
    xmin = max(float(pts[:, 0].min()) - margin_m, txmin)
    ymin = max(float(pts[:, 1].min()) - margin_m, tymin)
    xmax = min(float(pts[:, 0].max()) + margin_m, txmax)
    ymax = min(float(pts[:, 1].max()) + margin_m, tymax)
    if xmax <= xmin or ymax <= ymin:  # everything outside the terrain: a one-cell grid at the terrain corner
        xmin, ymin, xmax, ymax = txmin, tymin, txmin + cell_m, tymin + cell_m
    cell = float(cell_m)
    while True:
        nx_, ny_ = math.ceil((xmax - xmin) / cell), math.ceil((ymax - ymin) / cell)
        if nx_ * ny_ <= max_cells and (max_fft_cells is None or fft_cells(nx_, ny_, footprint_m, cell) <= max_fft_cells):
            break
        cell *= 2.0
    x0 = math.floor(xmin / cell) * cell
    y0 = math.floor(ymin / cell) * cell
    x0, y0 = max(x0, math.ceil(txmin / cell) * cell), max(y0, math.ceil(tymin / cell) * cell)
    nx = max(1, int(math.floor((xmax - x0) / cell)))
    ny = max(1, int(math.floor((ymax - y0) / cell)))
    return GridSpec(x0, y0, cell, nx, ny)


def rasterise(grid: GridSpec, x: np.ndarray, y: np.ndarray, vol: np.ndarray) -> tuple[np.ndarray, float]:
    """Volume per cell (ny, nx) float64 (same unit as ``vol``) and the off-grid volume.

    Cloud-in-cell: each parcel's volume goes to its four nearest cell centres with bilinear weights.
    """
    fx = (np.asarray(x) - grid.x0) / grid.cell - 0.5
    fy = (np.asarray(y) - grid.y0) / grid.cell - 0.5
    ix = np.floor(fx)
    iy = np.floor(fy)
    inside = (ix >= 0) & (ix + 1 < grid.nx) & (iy >= 0) & (iy + 1 < grid.ny) & np.isfinite(fx) & np.isfinite(fy)
    v = np.asarray(vol, dtype=np.float64)
    off = float(v[~inside].sum())
    tx = (fx - ix)[inside]
    ty = (fy - iy)[inside]
    v = v[inside]
    i00 = (iy[inside].astype(np.int64) * grid.nx + ix[inside].astype(np.int64))
    n = grid.nx * grid.ny
    idx = np.concatenate([i00, i00 + 1, i00 + grid.nx, i00 + grid.nx + 1])
    w = np.concatenate([v * (1 - tx) * (1 - ty), v * tx * (1 - ty), v * (1 - tx) * ty, v * tx * ty])
    acc = np.bincount(idx, weights=w, minlength=n) if idx.size else np.zeros(n)
    return acc.reshape(grid.ny, grid.nx), off


def disc_reach(radius_cells: float) -> int:
    """Half-width k (cells) of :func:`disc_kernel`'s (2k+1)² square for a disc of ``radius_cells``."""
    return int(math.ceil(radius_cells)) + 1


def disc_kernel(radius_cells: float, sub: int = 4) -> np.ndarray:
    """Square kernel (2k+1)² of a uniform disc of ``radius_cells`` (cell units), area-weighted, sum 1.

    Each cell's weight is the count of its ``sub`` × ``sub`` sample points inside the disc, counted one
    sample offset pair at a time (memory: a few (2k+1)² arrays, not (2k·sub)²)."""
    k = disc_reach(radius_cells)
    off = (np.arange(sub) + 0.5) / sub - 0.5
    c = np.arange(-k, k + 1)
    r2 = max(radius_cells, 0.5 / sub) ** 2
    sq = [(c + o) ** 2 for o in off]  # (2k+1,) per sample offset
    counts = np.zeros((2 * k + 1, 2 * k + 1), dtype=np.int64)
    for sy in sq:
        for sx in sq:
            counts += (sy[:, None] + sx[None, :]) <= r2
    ker = counts.astype(np.float64)
    return ker / ker.sum()


def _fft_len(n: int) -> int:
    """Smallest 2^a 3^b 5^c >= n (fast pocketfft sizes)."""
    best = 1 << max(n - 1, 1).bit_length()
    p5 = 1
    while p5 < 2 * n:
        p35 = p5
        while p35 < 2 * n:
            m = p35
            while m < n:
                m *= 2
            best = min(best, m)
            p35 *= 3
        p5 *= 5
    return best


def rasterise_discs(grid: GridSpec, x: np.ndarray, y: np.ndarray, vol: np.ndarray, radius: np.ndarray,
                    rel_bin: float = REL_BIN, inner: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Volume per cell (ny, nx) with each parcel spread over its disc (radius m), and the off-grid volume.

    Radii are interpolated between log-spaced nodes ``rel_bin`` apart: each parcel's volume is shared
    linearly between the discs of the two nodes around its radius (one FFT convolution per node).
    ``inner``: inner radii (m; 0 for a disc) of parcels landing on an annulus (a hollow cone's ring,
    :mod:`vinecli.spray.nozzle_pattern`): its outer disc carries ``v R_o² / (R_o² - R_i²)``, the inner one takes
    ``v R_i² / (R_o² - R_i²)`` off (the sum is linear, so the annulus is exact up to the radius nodes).
    """
    x, y, v, r = (np.asarray(a, dtype=np.float64).ravel() for a in (x, y, vol, radius))
    if v.size == 0:
        return np.zeros((grid.ny, grid.nx)), 0.0
    if inner is not None:
        ri = np.clip(np.asarray(inner, dtype=np.float64).ravel(), 0.0, 0.999 * r)
        ring = ri > 0.0
        frac = np.where(ring, ri * ri / np.maximum(r * r - ri * ri, 1e-300), 0.0)
        x, y = np.concatenate([x, x[ring]]), np.concatenate([y, y[ring]])
        v = np.concatenate([v * (1.0 + frac), -(v * frac)[ring]])
        r = np.concatenate([r, ri[ring]])
    rc = np.maximum(r, 0.0) / grid.cell
    # log-spaced radius nodes r_b = r0 e^(b rel); a parcel is shared linearly between its two nodes,
    # so the footprint edge moves smoothly with the radius (no steps where a bin changes)
    r0 = max(float(rc.min()), 0.5)
    f = np.log(np.maximum(rc, r0) / r0) / rel_bin
    b0 = np.floor(f).astype(np.int64)
    w1 = f - b0
    bidx = np.concatenate([b0, b0 + 1])
    vv = np.concatenate([v * (1.0 - w1), v * w1])
    x, y = np.concatenate([x, x]), np.concatenate([y, y])
    keep = vv != 0.0  # an annulus's inner disc carries a negative volume
    bins, v, x, y = bidx[keep], vv[keep], x[keep], y[keep]
    ubins = np.unique(bins)
    radii = [r0 * math.exp(float(b) * rel_bin) for b in ubins]
    reach = max(disc_reach(rb) for rb in radii)  # the widest disc's half-width, cells
    # convolve only the window the parcels reach: their bounding box (inside the grid + reach) grown by 2k
    cx = (x - grid.x0) / grid.cell
    cy = (y - grid.y0) / grid.cell
    near = (cx > -reach - 1) & (cx < grid.nx + reach + 1) & (cy > -reach - 1) & (cy < grid.ny + reach + 1)
    off = float(v[~near].sum())  # too far to reach the grid at all
    if not near.any():
        return np.zeros((grid.ny, grid.nx)), off
    ix0 = max(int(np.floor(cx[near].min())) - 1, -reach)
    ix1 = min(int(np.ceil(cx[near].max())) + 2, grid.nx + reach)
    iy0 = max(int(np.floor(cy[near].min())) - 1, -reach)
    iy1 = min(int(np.ceil(cy[near].max())) + 2, grid.ny + reach)
    win = GridSpec(grid.x0 + ix0 * grid.cell, grid.y0 + iy0 * grid.cell, grid.cell, ix1 - ix0, iy1 - iy0)
    # each node's parcels on the window; a node with nothing on it (its parcels beyond the window's cells: far-field
    # bins of a drift far wider than the grid) adds nothing, so neither its disc nor its width enters the convolution
    accs, kers = [], []
    for b, rb in zip(ubins, radii, strict=True):
        sel = near & (bins == b)
        acc, o = rasterise(win, x[sel], y[sel], v[sel])
        off += o
        if acc.any():
            accs.append(acc)
            kers.append(disc_kernel(rb))
    if not accs:
        return np.zeros((grid.ny, grid.nx)), off
    k = max(ker.shape[0] // 2 for ker in kers)  # one padded grid for the nodes that land on the window
    sy, sx = _fft_len(win.ny + 2 * k), _fft_len(win.nx + 2 * k)
    spec = None
    for acc, ker in zip(accs, kers, strict=True):
        kb = ker.shape[0] // 2
        kpad = np.zeros((2 * k + 1, 2 * k + 1))
        kpad[k - kb: k + kb + 1, k - kb: k + kb + 1] = ker  # centred in the common (2k+1)² support
        term = np.fft.rfft2(acc, (sy, sx)) * np.fft.rfft2(kpad, (sy, sx))
        spec = term if spec is None else spec + term
    full = np.fft.irfft2(spec, (sy, sx))
    # linear convolution: full[i, j] = sum acc[i - a, j - b] ker[a, b]: window cell (i, j) is full[i + k, j + k]
    conv = full[: win.ny + 2 * k, : win.nx + 2 * k]
    out = np.zeros((grid.ny, grid.nx))
    # grid cell (iy, ix) = window cell (iy - iy0, ix - ix0) -> full[iy - iy0 + k, ix - ix0 + k]
    gy0, gy1 = max(0, iy0 - k), min(grid.ny, iy1 + k)
    gx0, gx1 = max(0, ix0 - k), min(grid.nx, ix1 + k)
    out[gy0:gy1, gx0:gx1] = conv[gy0 - iy0 + k: gy1 - iy0 + k, gx0 - ix0 + k: gx1 - ix0 + k]
    off += float(conv.sum() - out.sum())
    np.maximum(out, 0.0, out=out)  # FFT round-off leaves ~1e-20 negatives in empty cells
    return out, off


def flat_height(z: float) -> HeightFn:
    """Vectorised height (m ENU) of flat ground at ``z``; a height grid's is :meth:`TerrainGrid.heights`."""
    def flat(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.full(np.broadcast(x, y).shape, float(z))
    return flat
