"""A regular height grid in the world frame (ENU, m) with a fast bilinear lookup.

The grid is what ``World.terrain_height`` queries every physics step and what a heightfield
terrain is built from. Stored as ``terrain/grid.npz`` in a built world: ``z`` (ny, nx) float32
heights (ENU z, m, relative to the geodetic origin's altitude), row 0 at ``y0`` (south) and
column 0 at ``x0`` (west), spacing ``dx``, ``dy`` (m).
"""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["TerrainGrid"]


@dataclass
class TerrainGrid:
    """Heights ``z[iy, ix]`` at ``(x0 + ix dx, y0 + iy dy)`` (ENU, m)."""

    z: np.ndarray
    x0: float
    y0: float
    dx: float
    dy: float
    _flat: array = field(init=False, repr=False)
    # typed (ints, not numpy's Any): compiled, height() is plain C arithmetic
    nx: int = field(init=False, repr=False, compare=False)
    ny: int = field(init=False, repr=False, compare=False)
    _ix_max: int = field(init=False, repr=False, compare=False)
    _iy_max: int = field(init=False, repr=False, compare=False)
    # (index, z00, z01, z10, z11) of the cell height() read last: the loop, the autopilot and the rangefinder ask
    # about the same few cells step after step, and reading ``_flat`` boxes each value (one tuple: threads sharing
    # the grid read a consistent cell)
    _cell: tuple[int, float, float, float, float] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self.z = np.ascontiguousarray(self.z, dtype=np.float64)
        if self.z.ndim != 2 or min(self.z.shape) < 2:
            raise ValueError("height grid must be 2-D with at least 2×2 samples")
        if not np.isfinite(self.z).all():
            raise ValueError("height grid contains NaN/inf")
        self.ny, self.nx = int(self.z.shape[0]), int(self.z.shape[1])
        self._flat = array("d", self.z.ravel().tobytes())
        self._ix_max = self.nx - 1
        self._iy_max = self.ny - 1
        self._cell = (-1, 0.0, 0.0, 0.0, 0.0)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax), m ENU."""
        return (self.x0, self.y0, self.x0 + (self.nx - 1) * self.dx, self.y0 + (self.ny - 1) * self.dy)

    @property
    def z_range(self) -> tuple[float, float]:
        """(zmin, zmax), m ENU."""
        return (float(self.z.min()), float(self.z.max()))

    def height(self, x: float, y: float) -> float:
        """Bilinear height (m, ENU) at (x, y); positions outside the grid are clamped to its edge."""
        fx = (x - self.x0) / self.dx
        fy = (y - self.y0) / self.dy
        if fx < 0.0:
            fx = 0.0
        elif fx > self._ix_max:
            fx = float(self._ix_max)
        if fy < 0.0:
            fy = 0.0
        elif fy > self._iy_max:
            fy = float(self._iy_max)
        ix = int(fx)
        iy = int(fy)
        if ix >= self._ix_max:
            ix = self._ix_max - 1
        if iy >= self._iy_max:
            iy = self._iy_max - 1
        tx = fx - ix
        ty = fy - iy
        i = iy * self.nx + ix
        cell = self._cell
        if cell[0] != i:
            z = self._flat
            cell = (i, z[i], z[i + 1], z[i + self.nx], z[i + self.nx + 1])
            self._cell = cell
        _, z00, z01, z10, z11 = cell
        return (z00 + (z01 - z00) * tx) * (1.0 - ty) + (z10 + (z11 - z10) * tx) * ty

    def heights(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`height` for arrays of positions."""
        fx = np.clip((np.asarray(x, float) - self.x0) / self.dx, 0, self._ix_max)
        fy = np.clip((np.asarray(y, float) - self.y0) / self.dy, 0, self._iy_max)
        ix = np.minimum(fx.astype(int), self._ix_max - 1)
        iy = np.minimum(fy.astype(int), self._iy_max - 1)
        tx, ty = fx - ix, fy - iy
        z = self.z
        return (z[iy, ix] * (1 - tx) + z[iy, ix + 1] * tx) * (1 - ty) + (z[iy + 1, ix] * (1 - tx) + z[iy + 1, ix + 1] * tx) * ty

    def max_in_box(self, xmin: float, ymin: float, xmax: float, ymax: float) -> float:
        """Highest grid height within a box (and at its corners), m."""
        xs = np.linspace(xmin, xmax, 5)
        ys = np.linspace(ymin, ymax, 5)
        gx, gy = np.meshgrid(xs, ys)
        best = float(self.heights(gx.ravel(), gy.ravel()).max())
        i0 = int(np.clip(np.ceil((xmin - self.x0) / self.dx), 0, self._ix_max))
        i1 = int(np.clip(np.floor((xmax - self.x0) / self.dx), 0, self._ix_max))
        j0 = int(np.clip(np.ceil((ymin - self.y0) / self.dy), 0, self._iy_max))
        j1 = int(np.clip(np.floor((ymax - self.y0) / self.dy), 0, self._iy_max))
        if i1 >= i0 and j1 >= j0:
            best = max(best, float(self.z[j0 : j1 + 1, i0 : i1 + 1].max()))
        return best

    def max_slope(self) -> float:
        """Upper bound of |∇h| of the bilinear surface (m/m): in each cell the partial derivatives lie
        between those along its edges."""
        sx = float(np.abs(np.diff(self.z, axis=1)).max()) / self.dx
        sy = float(np.abs(np.diff(self.z, axis=0)).max()) / self.dy
        return float(np.hypot(sx, sy))

    def preview(self, max_side: int = 129) -> dict[str, np.ndarray]:
        """Down-sampled copy for plots: ``x`` (nx,), ``y`` (ny,), ``z`` (ny, nx) with nx, ny ≤ max_side."""
        sx = max(1, int(np.ceil(self.nx / max_side)))
        sy = max(1, int(np.ceil(self.ny / max_side)))
        ix = np.arange(0, self.nx, sx)
        iy = np.arange(0, self.ny, sy)
        return {"x": self.x0 + ix * self.dx, "y": self.y0 + iy * self.dy, "z": self.z[np.ix_(iy, ix)].astype(np.float32)}

    def save(self, path: Path) -> Path:
        """Write ``grid.npz``."""
        np.savez_compressed(path, z=self.z.astype(np.float32), x0=self.x0, y0=self.y0, dx=self.dx, dy=self.dy)
        return Path(path)

    @classmethod
    def load(cls, path: Path) -> TerrainGrid:
        """Read a ``grid.npz``."""
        with np.load(path) as d:
            return cls(d["z"], float(d["x0"]), float(d["y0"]), float(d["dx"]), float(d["dy"]))
