"""A raster on the world's local grid -> an image Leaflet can lay over the map: resampled onto a grid regular in
Web-Mercator metres (what Leaflet stretches an image overlay over), so the cells land where the world's
georeference puts them even when the world's grid is not aligned with north (a UTM grid is off by its
convergence, 1.8 deg at the sample vineyard). The exact georeference is evaluated on a 17 x 17 lattice of output
pixels and interpolated bilinearly in between (the map is smooth: the error is far below a pixel), like GDAL's
approximate transformer. Downsampled to ``max_px`` on the long side: a PNG of tens of kB, never megabytes of JSON.
Hover values travel as 16-bit integers, deflated and base64-encoded.
"""

from __future__ import annotations

import base64
import io
import math
import zlib
from typing import Any

import numpy as np

from vinecli.gis.georef import Georef

__all__ = ["overlay", "png_data_uri", "resize_bilinear"]

R_EARTH = 6378137.0  # m, the Web-Mercator sphere (EPSG:3857)
LATTICE = 17
NO_VALUE = 65535
#: zlib level of the overlays' PNGs: 3 deflates the 9 overlays of the 5 CI maps in 0.05 s, not 0.15 s (level 6),
#: for 3 % more bytes (569 kB, not 554 kB)
OVERLAY_PNG_LEVEL = 3


def _to_merc(lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lam, phi = np.radians(lon), np.radians(lat)
    return R_EARTH * lam, R_EARTH * np.log(np.tan(np.pi / 4 + phi / 2))


def _from_merc(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.degrees(x / R_EARTH), np.degrees(2 * np.arctan(np.exp(y / R_EARTH)) - np.pi / 2)


def _lerp_matrix(n: int) -> np.ndarray:
    """(n, LATTICE) weights that interpolate a lattice of :data:`LATTICE` nodes spread over n pixels linearly at
    every pixel (each row: two neighbouring nodes, weights summing to 1)."""
    f = np.arange(n) * (LATTICE - 1) / max(n - 1, 1)
    i = np.minimum(f.astype(int), LATTICE - 2)
    u = f - i
    m = np.zeros((n, LATTICE))
    m[np.arange(n), i] = 1.0 - u
    m[np.arange(n), i + 1] = u
    return m


def _local_of_pixels(georef: Georef, mx: tuple[float, float], my: tuple[float, float], w: int, h: int
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Local (x, y) m of every output pixel centre (h, w); row 0 north. The lattice's bilinear interpolation is
    separable: a (h, 17) and a (17, w) weight matrix on either side of it."""
    jj = np.linspace(0, w - 1, LATTICE)
    ii = np.linspace(0, h - 1, LATTICE)
    gx = mx[0] + (jj + 0.5) * (mx[1] - mx[0]) / w
    gy = my[1] - (ii + 0.5) * (my[1] - my[0]) / h
    lon, lat = _from_merc(*np.meshgrid(gx, gy))
    local = np.asarray(georef.from_lonlat(list(zip(lon.ravel().tolist(), lat.ravel().tolist(), strict=True))))
    lx, ly = local[:, 0].reshape(LATTICE, LATTICE), local[:, 1].reshape(LATTICE, LATTICE)
    rows, cols = _lerp_matrix(h), _lerp_matrix(w).T
    return rows @ lx @ cols, rows @ ly @ cols


def _sample(a: np.ndarray, ci: np.ndarray, cj: np.ndarray, smooth: bool, fill: float) -> np.ndarray:
    """``a`` (ny, nx) or (ny, nx, channels) at fractional cell indices (row, col): nearest, or bilinear between the
    four cells around (``smooth``: inside the cell centres' hull), ``fill`` outside."""
    ny, nx = a.shape[:2]
    extra = a.shape[2:]
    if smooth:
        eps = 1e-9
        inside = (ci >= -eps) & (ci <= ny - 1 + eps) & (cj >= -eps) & (cj <= nx - 1 + eps)
        i0 = np.clip(np.floor(ci), 0, max(ny - 2, 0)).astype(int)
        j0 = np.clip(np.floor(cj), 0, max(nx - 2, 0)).astype(int)
        i1, j1 = np.minimum(i0 + 1, ny - 1), np.minimum(j0 + 1, nx - 1)
        u = np.clip(ci - i0, 0.0, 1.0)[inside]
        v = np.clip(cj - j0, 0.0, 1.0)[inside]
        if extra:
            u, v = u[:, None], v[:, None]
        i0, i1, j0, j1 = i0[inside], i1[inside], j0[inside], j1[inside]
        af = a.astype(float, copy=False)
        out = np.full(ci.shape + extra, fill, dtype=float)
        out[inside] = ((af[i0, j0] * (1 - v) + af[i0, j1] * v) * (1 - u)
                       + (af[i1, j0] * (1 - v) + af[i1, j1] * v) * u)
        return out
    ri, rj = np.rint(ci).astype(int), np.rint(cj).astype(int)
    inside = (ri >= 0) & (ri < ny) & (rj >= 0) & (rj < nx)
    out = np.full(ci.shape + extra, fill, dtype=float)
    out[inside] = a[ri[inside], rj[inside]]
    return out


def resize_bilinear(a: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``a`` (ny, nx) resampled to ``shape`` bilinearly, corner cells on corner cells: scipy.ndimage's
    ``zoom(a, (shape[0] / ny, shape[1] / nx), order=1)`` for that output shape, in numpy."""
    ny, nx = a.shape
    ci = np.arange(shape[0]) * ((ny - 1) / max(shape[0] - 1, 1))
    cj = np.arange(shape[1]) * ((nx - 1) / max(shape[1] - 1, 1))
    return _sample(a, *np.meshgrid(ci, cj, indexing="ij"), smooth=True, fill=math.nan)


def _palette_image(rgba: np.ndarray) -> Any:
    """An RGBA image of at most 256 distinct colours as an exact palette image (its colours and their alphas as
    they are; Pillow's octree quantizer merges the neighbouring steps of a colour scale into bands), else None."""
    from PIL import Image

    packed = np.ascontiguousarray(rgba, dtype=np.uint8).view("<u4")[..., 0]
    colours, index = np.unique(packed, return_inverse=True)
    if colours.size > 256:
        return None
    img = Image.fromarray(index.reshape(packed.shape).astype(np.uint8), "P")
    table = colours.astype("<u4").view(np.uint8).reshape(-1, 4)
    img.putpalette(table[:, :3].ravel().tolist(), rawmode="RGB")
    img.info["transparency"] = bytes(table[:, 3].tolist())
    return img


def png_data_uri(rgba: np.ndarray) -> str:
    """An RGBA image (rows top to bottom) as a ``data:image/png;base64`` URI: grey + alpha when it is grey, an exact
    palette when it has at most 256 colours (a colour scale of 256 steps), else quantized to 256."""
    from PIL import Image

    img = Image.fromarray(np.ascontiguousarray(rgba, dtype=np.uint8), "RGBA")
    if np.array_equal(rgba[..., 0], rgba[..., 1]) and np.array_equal(rgba[..., 0], rgba[..., 2]):
        img = img.convert("LA")
    else:
        img = _palette_image(rgba) or img.quantize(colors=256, method=Image.Quantize.FASTOCTREE)
    buf = io.BytesIO()
    img.save(buf, format="PNG", compress_level=OVERLAY_PNG_LEVEL)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _encode_values(v: np.ndarray, digits: int) -> dict[str, Any]:
    """Values (h, w) as deflated little-endian uint16 steps (``10^-digits``, coarser when the range needs it) above
    ``offset`` (65535: no value)."""
    finite = v[np.isfinite(v)]
    lo = float(finite.min()) if finite.size else 0.0
    span = float(finite.max()) - lo if finite.size else 0.0
    step = max(10.0 ** -digits, span / 60000.0)
    q = np.full(v.shape, NO_VALUE, dtype="<u2")
    ok = np.isfinite(v)
    q[ok] = np.rint((v[ok] - lo) / step).astype("<u2")
    return {"offset": lo, "step": step, "deflated": base64.b64encode(zlib.compress(q.tobytes(), 6)).decode("ascii")}


def overlay(r: Any, georef: Georef, max_px: int = 640) -> dict[str, Any]:
    """A :class:`~vinecli.report.fieldmap.map_model.Raster` as ``{"png", "bounds": [[S, W], [N, E]], "w", "h",
    "values": {...} | absent, "label", "unit", "digits", "ref", "ref_label"}``."""
    ny, nx = r.rgba.shape[:2]
    cell = float(r.cell_m)
    x0, y0, x1, y1 = r.x0_m, r.y0_m, r.x0_m + nx * cell, r.y0_m + ny * cell
    t = np.linspace(0.0, 1.0, 9)
    edge = [*((x0 + (x1 - x0) * u, y0) for u in t), *((x1, y0 + (y1 - y0) * u) for u in t),
            *((x0 + (x1 - x0) * u, y1) for u in t), *((x0, y0 + (y1 - y0) * u) for u in t)]
    ll = np.asarray(georef.to_lonlat(edge))
    mxs, mys = _to_merc(ll[:, 0], ll[:, 1])
    mx, my = (float(mxs.min()), float(mxs.max())), (float(mys.min()), float(mys.max()))
    k = math.cos(math.radians(float(ll[:, 1].mean())))  # ground metres per Mercator metre
    w0, h0 = (mx[1] - mx[0]) * k / cell, (my[1] - my[0]) * k / cell
    f = min(1.0, max_px / max(w0, h0, 1.0))
    w, h = max(2, int(math.ceil(w0 * f))), max(2, int(math.ceil(h0 * f)))
    ci, cj = _cell_indices(georef, mx, my, w, h, x0, y0, cell)
    rgba = _sample(r.rgba, ci, cj, r.smooth, 0.0)
    out: dict[str, Any] = {"png": png_data_uri(np.clip(np.rint(rgba), 0, 255).astype(np.uint8)), "w": w, "h": h,
                           "label": r.label, "unit": r.unit, "digits": r.digits, "ref": r.ref, "ref_label": r.ref_label}
    lon, lat = _from_merc(np.array(mx), np.array(my))
    out["bounds"] = [[float(lat[0]), float(lon[0])], [float(lat[1]), float(lon[1])]]
    if r.values is not None:
        g = r.values_px / max(w, h)
        vw, vh = max(2, int(math.ceil(w * g))), max(2, int(math.ceil(h * g)))
        vi, vj = _cell_indices(georef, mx, my, vw, vh, x0, y0, cell)
        out["values"] = {"w": vw, "h": vh, **_encode_values(_sample(r.values, vi, vj, False, math.nan), r.digits)}
    return out


def _cell_indices(georef: Georef, mx: tuple[float, float], my: tuple[float, float], w: int, h: int, x0: float,
                  y0: float, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Fractional (row, col) source cell of every pixel of a (h, w) output grid over the Mercator box."""
    lx, ly = _local_of_pixels(georef, mx, my, w, h)
    return (ly - y0) / cell - 0.5, (lx - x0) / cell - 0.5
