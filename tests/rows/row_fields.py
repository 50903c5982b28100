"""Synthetic fields with known rows for the row-detection tests (importable helper, not a test module).

A field is a height grid (x east, y north, m) of ground (slope, undulation, noise) with canopy ridges
of height ``canopy_m`` and half-width ``0.3 x spacing`` along known centre lines. Row ``i`` runs along
direction ``direction_deg`` at lateral offset ``offset + i x spacing`` plus ``amp x sin(2 pi t / wavelength)``
(curved rows), over ``t_range`` (m along the rows), with canopy gaps ``gaps`` ([t0, t1] intervals).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass
class Field:
    """Parameters of a synthetic row field (see the module docstring); distances m, angles deg from east."""

    width_m: float = 60.0
    height_m: float = 40.0
    res_m: float = 0.1
    direction_deg: float = 0.0
    spacing_m: float = 2.5
    n_rows: int = 12
    offset_m: float = 0.0
    t_range: tuple[float, float] = (-25.0, 25.0)
    amp_m: float = 0.0
    wavelength_m: float = 40.0
    gaps: list[tuple[float, float]] = field(default_factory=list)
    canopy_m: float = 1.2
    slope: tuple[float, float] = (0.0, 0.0)  # dz/dx, dz/dy
    undulation_m: float = 0.0
    noise_m: float = 0.03
    plants_m: float = 0.0  # > 0: canopy made of plants this far apart (with small random gaps)
    seed: int = 0
    canopy_half_m: float | None = None  # half-width of a row's canopy, m (default 0.3 x spacing)
    plant_frac: float = 0.45  # a plant's half-length along the row as a share of ``plants_m``
    missing: float = 0.0  # share of plants missing (dead or not yet planted), at random
    grass_m: float = 0.0  # > 0: a clumpy grass strip this tall down the middle of every inter-row

    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell-centre coordinates x (east), y (north) of the grid, m, centred on 0."""
        x = (np.arange(int(round(self.width_m / self.res_m))) + 0.5) * self.res_m - self.width_m / 2
        y = (np.arange(int(round(self.height_m / self.res_m))) + 0.5) * self.res_m - self.height_m / 2
        return x, y

    def _uv(self) -> tuple[np.ndarray, np.ndarray]:
        th = math.radians(self.direction_deg)
        return np.array([math.cos(th), math.sin(th)]), np.array([-math.sin(th), math.cos(th)])

    def row_offset(self, i: int) -> float:
        """Lateral offset (m, along the left normal) of row ``i`` at t = 0."""
        return self.offset_m + (i - (self.n_rows - 1) / 2) * self.spacing_m

    def centre(self, i: int, t: np.ndarray) -> np.ndarray:
        """Lateral offset of row ``i`` at positions ``t`` along the rows, m."""
        return self.row_offset(i) + self.amp_m * np.sin(2 * np.pi * t / self.wavelength_m)

    def truth(self, step: float = 0.1) -> list[np.ndarray]:
        """True centre lines, (n, 2) arrays of x, y (m), over ``t_range``."""
        u, n = self._uv()
        t = np.arange(self.t_range[0], self.t_range[1] + step / 2, step)
        return [np.column_stack([t * u[0] + self.centre(i, t) * n[0], t * u[1] + self.centre(i, t) * n[1]])
                for i in range(self.n_rows)]

    def heights(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(z[j, i], x[i], y[j]): the field's heights, m."""
        x, y = self.axes()
        X, Y = np.meshgrid(x, y)
        u, n = self._uv()
        t = X * u[0] + Y * u[1]
        s = X * n[0] + Y * n[1]
        rng = np.random.default_rng(self.seed)
        z = 100.0 + self.slope[0] * X + self.slope[1] * Y + self.undulation_m * np.sin(X / 7.0) * np.cos(Y / 9.0)
        half = self.canopy_half_m if self.canopy_half_m is not None else 0.3 * self.spacing_m
        along = (t >= self.t_range[0]) & (t <= self.t_range[1])
        for a, b in self.gaps:
            along &= ~((t >= a) & (t <= b))
        canopy = np.zeros_like(z)
        for i in range(self.n_rows):
            d = s - self.centre(i, t)
            c = self.canopy_m * np.clip(1.0 - (d / half) ** 2, 0.0, None)
            if self.plants_m > 0:
                phase = rng.uniform(0, self.plants_m)
                pos = np.mod(t - phase, self.plants_m) - self.plants_m / 2
                size = self.plants_m * self.plant_frac
                c = c * np.clip(1.0 - (pos / size) ** 2, 0.0, None) ** 0.5
                if self.missing > 0:
                    k = np.floor((t - phase) / self.plants_m).astype(int)
                    dead = rng.random(int(k.max() - k.min()) + 1) < self.missing
                    c = np.where(dead[k - k.min()], 0.0, c)
            canopy = np.maximum(canopy, c)
        z = z + np.where(along, canopy, 0.0) + rng.normal(0.0, self.noise_m, z.shape)
        if self.grass_m > 0:
            z = z + self._grass(s, t, rng)
        return z, x, y

    def _grass(self, s: np.ndarray, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Grass strips half a spacing wide down the middle of the block's inter-rows, clumps
        ~0.3 m across of 0-2x ``grass_m``."""
        from scipy.ndimage import gaussian_filter

        clumps = gaussian_filter(rng.normal(0.0, 1.0, s.shape), 0.15 / self.res_m)
        clumps = np.clip(1.0 + clumps / clumps.std(), 0.0, 2.0)
        mid = np.mod(s - self.row_offset(0), self.spacing_m)  # 0 on a (straight) row, spacing / 2 between rows
        strip = np.abs(mid - self.spacing_m / 2) <= self.spacing_m / 4
        block = (t >= self.t_range[0]) & (t <= self.t_range[1])
        block &= (s >= self.row_offset(0)) & (s <= self.row_offset(self.n_rows - 1))
        return self.grass_m * clumps * (strip & block)


def _window(x: np.ndarray, y: np.ndarray, cx: float, cy: float, r: float) -> tuple[slice, slice]:
    """The (rows, columns) of the grid with cell centres ``x[i]``, ``y[j]`` (ascending, m) that hold every cell
    within ``r`` (m) of (``cx``, ``cy``), with a cell to spare on each side."""
    i0, i1 = np.searchsorted(x, [cx - r, cx + r])
    j0, j1 = np.searchsorted(y, [cy - r, cy + r])
    return slice(max(int(j0) - 1, 0), int(j1) + 1), slice(max(int(i0) - 1, 0), int(i1) + 1)


def lateral_errors(row: list[tuple[float, float]], truth: np.ndarray, end_margin_m: float = 0.3) -> np.ndarray:
    """Distances (m) from points along a detected row (every 5 cm) to the true centre line, for the points
    whose projection falls inside the true line (``end_margin_m`` from its ends)."""
    from shapely.geometry import LineString, Point

    line = LineString(truth)
    det = LineString(row)
    out = []
    for d in np.arange(0.0, det.length + 1e-9, 0.05):
        p = det.interpolate(d)
        proj = line.project(p)
        if end_margin_m <= proj <= line.length - end_margin_m:
            out.append(line.distance(Point(p.x, p.y)))
    return np.array(out)


def match_rows(rows: list[list[tuple[float, float]]], truth: list[np.ndarray]) -> list[tuple[int, float, float]]:
    """For each true row, (index of the nearest detected row, its max lateral error m, its length / true length)."""
    from shapely.geometry import LineString

    out = []
    for tr in truth:
        tl = LineString(tr)
        mid = tl.interpolate(0.5, normalized=True)
        k = int(np.argmin([LineString(r).distance(mid) for r in rows]))
        err = lateral_errors(rows[k], tr)
        out.append((k, float(err.max()) if err.size else math.inf, LineString(rows[k]).length / tl.length))
    return out


@dataclass
class YoungCrop:
    """A young row crop as a 1 cm drone DSM sees it: single plants (``radius_m`` across, up to
    ``tall_m`` high, every ``step_m`` along the rows, ``missing`` of them absent) on rough bare soil (correlated
    roughness at 3 and 15 cm, clods 2-6 cm across, a tilt, wheel tracks between every 4th pair of rows). Most of the
    relief is soil and plant-vs-gap along the rows: the comb explains 11-13 % of it."""

    width_m: float = 9.0
    height_m: float = 6.0
    res_m: float = 0.01
    spacing_m: float = 0.77
    direction_deg: float = 0.0
    step_m: float = 0.17
    radius_m: float = 0.07
    tall_m: float = 0.15
    missing: float = 0.15
    rough_m: float = 0.012
    offset_m: float = 0.1
    seed: int = 0

    def _frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        x = (np.arange(int(round(self.width_m / self.res_m))) + 0.5) * self.res_m - self.width_m / 2
        y = (np.arange(int(round(self.height_m / self.res_m))) + 0.5) * self.res_m - self.height_m / 2
        X, Y = np.meshgrid(x, y)
        th = math.radians(self.direction_deg)
        return x, y, X * math.cos(th) + Y * math.sin(th), -X * math.sin(th) + Y * math.cos(th)

    def row_offsets(self) -> list[float]:
        """Lateral offsets (m, along the left normal) of the rows inside the grid."""
        _, _, _, s = self._frame()
        k0, k1 = int(math.floor((s.min() - self.offset_m) / self.spacing_m)), int(math.ceil((s.max() - self.offset_m) / self.spacing_m))
        return [self.offset_m + k * self.spacing_m for k in range(k0, k1 + 1)
                if s.min() + 0.1 <= self.offset_m + k * self.spacing_m <= s.max() - 0.1]

    def heights(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(z[j, i], x[i], y[j]): the field's heights, m."""
        from scipy.ndimage import gaussian_filter

        rng = np.random.default_rng(self.seed)
        x, y, t, s = self._frame()
        X, Y = np.meshgrid(x, y)
        z = 200.0 + 0.02 * X + 0.01 * Y
        fine = gaussian_filter(rng.normal(size=X.shape), 3)
        z += self.rough_m * fine / fine.std() + 1.5 * self.rough_m * gaussian_filter(rng.normal(size=X.shape), 15) / 0.02
        for _ in range(int(self.width_m * self.height_m * 3)):  # clods
            cx, cy, r = rng.uniform(x[0], x[-1]), rng.uniform(y[0], y[-1]), rng.uniform(0.02, 0.06)
            w = _window(x, y, cx, cy, r)  # the cells a clod can touch: the same values as the whole grid's
            d2 = (X[w] - cx) ** 2 + (Y[w] - cy) ** 2
            z[w] += np.where(d2 < r * r, rng.uniform(0.01, 0.04) * np.sqrt(np.clip(1 - d2 / (r * r), 0, 1)), 0.0)
        canopy = np.zeros_like(z)
        cos, sin = math.cos(math.radians(self.direction_deg)), math.sin(math.radians(self.direction_deg))
        for sc in self.row_offsets():
            tt = float(t.min()) + rng.uniform(0, self.step_m)
            while tt < t.max():
                if rng.random() > self.missing:
                    r, h = self.radius_m * rng.uniform(0.6, 1.3), self.tall_m * rng.uniform(0.5, 1.4)
                    ps, pt = sc + rng.normal(0, 0.02), tt + rng.normal(0, 0.02)
                    w = _window(x, y, pt * cos - ps * sin, pt * sin + ps * cos, r * math.sqrt(2.0))
                    sw, tw, cw = s[w], t[w], canopy[w]  # the plant's square lies inside this window
                    sel = (np.abs(sw - ps) < r) & (np.abs(tw - pt) < r)
                    d2 = (sw[sel] - ps) ** 2 + (tw[sel] - pt) ** 2
                    leaf = h * np.clip(1 - d2 / (r * r), 0, 1) ** 0.5 * (0.6 + 0.4 * rng.random(d2.shape))
                    cw[sel] = np.maximum(cw[sel], leaf)
                tt += self.step_m * rng.uniform(0.7, 1.3)
        z = z + canopy
        for sc in self.row_offsets()[::4]:  # wheel tracks
            z -= 0.03 * np.exp(-((s - sc - self.spacing_m / 2) / 0.15) ** 2)
        return z, x, y
