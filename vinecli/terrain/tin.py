"""Triangulated irregular networks (TINs) of height grids: pydelatin meshing, exact error
measurement, crack-free border stitching and export.

A TIN here lives in *pixel* coordinates: integer vertex (col, row) positions of a grid (row 0 =
north), z taken from the grid, triangles as vertex-index triples. Conversion to metres happens
only at export.

The functions are top-level and picklable: :mod:`vinecli.terrain.tiles` runs them in a spawned
process pool. pydelatin holds the GIL while meshing (4 meshes of 513² on 2 threads took as long
as 4 in a row), so threads would not help.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass
class Tin:
    """A TIN of one tile. ``cols``/``rows``: (V,) int64 pixel positions in the *full* raster;
    ``tris``: (T, 3) int64, counter-clockwise seen from above (normals up)."""

    cols: np.ndarray
    rows: np.ndarray
    tris: np.ndarray


def mesh_grid(z: np.ndarray, col0: int, row0: int, max_error: float, max_triangles: int | None) -> Tin:
    """pydelatin TIN of ``z`` (float32 heights, tile of the raster at (col0, row0)).

    ``max_error`` (m, vertical) bounds |TIN - z| at every sample; ``max_triangles`` stops earlier.
    """
    from pydelatin import Delatin

    h, w = z.shape
    tin = Delatin(np.ascontiguousarray(z, dtype=np.float32), max_error=max_error, max_triangles=max_triangles)
    v = tin.vertices
    cols = np.rint(v[:, 0]).astype(np.int64)
    rows = (h - 1) - np.rint(v[:, 1]).astype(np.int64)  # pydelatin's y runs up (south -> north)
    tris = tin.triangles.astype(np.int64)
    return Tin(cols + col0, rows + row0, orient_up(cols, rows, tris))


def orient_up(cols: np.ndarray, rows: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Make every triangle counter-clockwise in (x east, y north) = (col, -row)."""
    x = cols[tris].astype(np.float64)
    y = -rows[tris].astype(np.float64)
    area2 = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    out = tris.copy()
    neg = area2 < 0
    out[neg] = out[neg][:, [0, 2, 1]]
    return out


def _pow2(n: np.ndarray) -> np.ndarray:
    return (1 << np.ceil(np.log2(np.maximum(n, 1))).astype(np.int64)).astype(np.int64)


def interpolate(tin: Tin, z: np.ndarray, col0: int, row0: int, chunk: int = 1 << 22) -> np.ndarray:
    """The TIN's height at every sample of the tile grid ``z`` (NaN where no triangle covers it).

    Exact linear (barycentric) interpolation on the TIN's own triangles, vectorised by grouping
    triangles by bounding-box size (rounded up to powers of two).
    """
    h, w = z.shape
    cx = (tin.cols - col0)[tin.tris]
    ry = (tin.rows - row0)[tin.tris]
    zv = z[ry, cx].astype(np.float64)
    out = np.full((h, w), np.nan)
    xmin, ymin = cx.min(1), ry.min(1)
    bw = _pow2(cx.max(1) - xmin + 1)
    bh = _pow2(ry.max(1) - ymin + 1)
    key = bw * (1 << 32) + bh
    order = np.argsort(key, kind="stable")
    keys, starts = np.unique(key[order], return_index=True)
    bounds = list(starts) + [order.size]
    for g in range(keys.size):
        idx = order[bounds[g]:bounds[g + 1]]
        gw, gh = int(bw[idx[0]]), int(bh[idx[0]])
        ox, oy = np.meshgrid(np.arange(gw), np.arange(gh))
        ox, oy = ox.ravel(), oy.ravel()
        step = max(1, chunk // ox.size)
        for s in range(0, idx.size, step):
            k = idx[s:s + step]
            px = xmin[k, None] + ox[None, :]
            py = ymin[k, None] + oy[None, :]
            x0, x1, x2 = (cx[k, i, None].astype(np.float64) for i in range(3))
            y0, y1, y2 = (ry[k, i, None].astype(np.float64) for i in range(3))
            det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
            with np.errstate(divide="ignore", invalid="ignore"):
                l0 = ((y1 - y2) * (px - x2) + (x2 - x1) * (py - y2)) / det
                l1 = ((y2 - y0) * (px - x2) + (x0 - x2) * (py - y2)) / det
            l2 = 1.0 - l0 - l1
            eps = -1e-9
            inside = (l0 >= eps) & (l1 >= eps) & (l2 >= eps) & (px < w) & (py < h) & (det != 0)
            val = l0 * zv[k, 0, None] + l1 * zv[k, 1, None] + l2 * zv[k, 2, None]
            out[py[inside], px[inside]] = val[inside]
    return out


def tin_error(tin: Tin, z: np.ndarray, col0: int, row0: int) -> tuple[float, float, int, int]:
    """(max |error|, RMS error, samples, uncovered samples) of the TIN against ``z``, metres."""
    zi = interpolate(tin, z, col0, row0)
    uncovered = int(np.isnan(zi).sum())
    d = zi - z.astype(np.float64)
    d = d[np.isfinite(d)]
    if d.size == 0:
        return float("inf"), float("inf"), 0, uncovered
    return float(np.max(np.abs(d))), float(np.sqrt(np.mean(d * d))), int(d.size), uncovered


def split_border(tin: Tin, axis: str, line: int, wanted: np.ndarray) -> Tin:
    """Insert vertices on a straight tile border so it holds every position in ``wanted``.

    ``axis`` "col": the border is the column ``line`` and ``wanted`` are rows; "row": the border
    is the row ``line`` and ``wanted`` are columns. Each boundary triangle whose border edge
    contains new points is replaced by a fan to its opposite vertex (winding kept).
    """
    on = (tin.cols if axis == "col" else tin.rows) == line
    along = tin.rows if axis == "col" else tin.cols
    have = np.unique(along[on])
    missing = np.setdiff1d(wanted, have)
    if missing.size == 0:
        return tin
    cols, rows, tris = list(tin.cols), list(tin.rows), tin.tris
    keep = np.ones(len(tris), dtype=bool)
    new_tris: list[tuple[int, int, int]] = []
    t_on = on[tris]
    cand = np.nonzero(t_on.sum(1) >= 2)[0]
    for t in cand:
        tri = tris[t]
        for e in range(3):
            a, b, o = int(tri[e]), int(tri[(e + 1) % 3]), int(tri[(e + 2) % 3])
            if not (on[a] and on[b]):
                continue
            pa, pb = int(along[a]), int(along[b])
            lo, hi = min(pa, pb), max(pa, pb)
            inner = missing[(missing > lo) & (missing < hi)]
            if inner.size == 0:
                continue
            seq = inner if pa < pb else inner[::-1]
            chain = [a]
            for p in seq:
                chain.append(len(cols))
                if axis == "col":
                    cols.append(line)
                    rows.append(int(p))
                else:
                    cols.append(int(p))
                    rows.append(line)
            chain.append(b)
            keep[t] = False
            new_tris.extend((chain[i], chain[i + 1], o) for i in range(len(chain) - 1))
            break
    if not new_tris:
        return tin
    tris2 = np.concatenate([tris[keep], np.asarray(new_tris, dtype=np.int64)])
    return Tin(np.asarray(cols, dtype=np.int64), np.asarray(rows, dtype=np.int64), tris2)


def export_mesh(tin: Tin, z_full_tile: np.ndarray, col0: int, row0: int, x_of_col: tuple[float, float],
                y_of_row: tuple[float, float], path: Path, fmt: str) -> dict[str, float]:
    """Write the TIN in metres: x = a + b·col, y = c + d·row, z from the grid. OBJ or binary STL.

    Returns bounds [xmin, ymin, zmin, xmax, ymax, zmax] (metres).
    """
    import trimesh

    x = x_of_col[0] + x_of_col[1] * tin.cols.astype(np.float64)
    y = y_of_row[0] + y_of_row[1] * tin.rows.astype(np.float64)
    zz = z_full_tile[tin.rows - row0, tin.cols - col0].astype(np.float64)
    verts = np.column_stack([x, y, zz])
    mesh = trimesh.Trimesh(vertices=verts, faces=tin.tris, process=False, validate=False)
    if fmt == "stl":
        mesh.export(path, file_type="stl")
    else:
        mesh.export(path, file_type="obj", include_normals=False, include_color=False, include_texture=False,
                    digits=6)
    lo, hi = verts.min(0), verts.max(0)
    return {"bounds_m": [float(lo[0]), float(lo[1]), float(lo[2]), float(hi[0]), float(hi[1]), float(hi[2])]}


# ----------------------------------------------------------------- worker entry points (picklable)
def mesh_task(args: tuple[np.ndarray, int, int, float, int | None]) -> Tin:
    """Process-pool task: mesh one tile."""
    z, col0, row0, max_error, max_triangles = args
    return mesh_grid(z, col0, row0, max_error, max_triangles)


def finish_task(args: tuple[Tin, np.ndarray, int, int, tuple[float, float], tuple[float, float], str, str]
                ) -> dict[str, float | int | list[float]]:
    """Process-pool task: measure one stitched tile against the grid and write its mesh file."""
    tin, z, col0, row0, xcol, yrow, path, fmt = args
    mx, rms, n, uncovered = tin_error(tin, z, col0, row0)
    info: dict[str, float | int | list[float]] = {"max_error_m": mx, "rms_error_m": rms, "samples": n,
                                                  "uncovered_samples": uncovered}
    info.update(export_mesh(tin, z, col0, row0, xcol, yrow, Path(path), fmt))
    return info
