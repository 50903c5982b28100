"""The raster layers of the field map: the terrain's hillshade (hover: elevation), the deposition in L/ha on the
colour scale of fig. 23 (fixed on the asked rate; hover: the cell's rate and its share of the asked rate) and the
canopy deposit of the spray budget (µL/cm² of leaf). Read from terrain_preview.npz, deposition.tif and
canopy_deposit.tif of the run directory; world ENU metres, rows of the arrays south first."""

from __future__ import annotations

from typing import Any

import numpy as np

from vinecli.report.fieldmap.context import MapContext
from vinecli.report.fieldmap.map_model import Legend, MapLayer, Raster

__all__ = ["canopy_layer", "deposition_layer", "hillshade_layer", "scale_legend"]

WET_SHARE = 0.02  # cells below this share of the scale's top stay transparent (as in fig. 23)
#: the terrain's hover grid, long side: 0.2 m cells over a 70 m field, so ridges and furrows (0.75 m apart on the
#: sample potato field) read as the hillshade shows them
HOVER_PX_TERRAIN = 320
OVERLAY_PX = 640  # the overlays' long side (fieldmap.overlay)
#: the deposition's hover grid, long side: twice the overlay's, so the cursor reads the cell under it, not a
#: neighbour (a swath 0.6 m wide at half height changes 3 % a 0.1 m cell; 256 px over a 54 m map read 0.2 m steps)
HOVER_PX_DEPOSITION = 2 * OVERLAY_PX


def _hex(rgba: Any) -> str:
    r, g, b = (int(round(255 * float(c))) for c in rgba[:3])
    return f"#{r:02x}{g:02x}{b:02x}"


def scale_legend(cmap: Any, norm: Any, marks: dict[float, str], unit: str) -> Legend:
    """A colour-scale legend: the colour map sampled along the norm, ticks at ``marks`` (value -> label)."""
    colours = [_hex(cmap(f)) for f in np.linspace(0.0, 1.0, 11)]
    ticks = [(float(np.clip(norm(v), 0.0, 1.0)), lab) for v, lab in sorted(marks.items())]
    return Legend(scale_colours=colours, ticks=ticks, unit=unit)


def _rgba(cmap: Any, norm: Any, v: np.ndarray, alpha: float, shown: np.ndarray) -> np.ndarray:
    """Colours of ``v`` in 255 steps of the scale and transparent where not ``shown``: 256 colours at most, which
    the overlay's PNG palette keeps exactly (no bands)."""
    steps = np.floor(np.clip(np.ma.filled(norm(np.nan_to_num(v)), 0.0), 0.0, 1.0) * 254.0 + 0.5) / 254.0
    rgba = np.rint(255 * cmap(steps)).astype(np.uint8)
    rgba[..., 3] = int(255 * alpha)
    rgba[~shown] = 0
    return rgba


def _terrain(ctx: MapContext) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(x, y, z[y, x]) of the ground, rows south first: the world's terrain grid (``terrain/grid.npz``, e.g. 5 cm
    cells, in block means no finer than the overlay, over the preview's extent: the map crops it to its view) when
    the world is there, else the run's terrain preview (every n-th sample of the grid, 129 at most on a side: ridges
    finer than its step would read wrong)."""
    grid = ctx.world_dir / "terrain" / "grid.npz" if ctx.world_dir is not None else None
    if grid is not None and grid.is_file():
        with np.load(grid) as g:
            z, dx, dy = g["z"].astype(float), float(g["dx"]), float(g["dy"])
            x0, y0 = float(g["x0"]), float(g["y0"])
        f = max(1, max(z.shape) // OVERLAY_PX)  # block means of f x f cells: no finer than the overlay shows
        if f > 1:
            ny, nx = (z.shape[0] // f) * f, (z.shape[1] // f) * f
            z = z[:ny, :nx].reshape(ny // f, f, nx // f, f).mean(axis=(1, 3))
            x0, y0, dx, dy = x0 + (f - 1) * dx / 2, y0 + (f - 1) * dy / 2, f * dx, f * dy
        x, y = x0 + dx * np.arange(z.shape[1]), y0 + dy * np.arange(z.shape[0])
        if ctx.preview is not None and ctx.preview["x"].size > 1 and ctx.preview["y"].size > 1:  # its crop (the view)
            px, py = ctx.preview["x"], ctx.preview["y"]
            kx = (x >= px.min() - dx) & (x <= px.max() + dx)
            ky = (y >= py.min() - dy) & (y <= py.max() + dy)
            if kx.sum() >= 2 and ky.sum() >= 2:
                x, y, z = x[kx], y[ky], z[np.ix_(ky, kx)]
    elif ctx.preview is not None:
        x, y, z = ctx.preview["x"], ctx.preview["y"], np.asarray(ctx.preview["z"], float)
    else:
        return None
    if x.size < 2 or y.size < 2:
        return None
    return (x, y[::-1], z[::-1]) if y[1] < y[0] else (x, y, z)


def hillshade_layer(ctx: MapContext) -> MapLayer | None:
    """The ground hillshaded (sun from the north-west, 3x vertical exaggeration); hover: its elevation (the world's
    origin altitude + world z, m, as the georeference maps heights)."""
    from matplotlib.colors import LightSource

    ground = _terrain(ctx)
    if ground is None:
        return None
    x, y, z = ground
    dx, dy = float(x[1] - x[0]), float(y[1] - y[0])
    if abs(dx - dy) > 1e-3 * max(dx, dy):  # square cells for the overlay, of the mean size (0.1 %: under a pixel)
        from vinecli.report.fieldmap.overlay import resize_bilinear

        c = float(np.sqrt(dx * dy))
        z = resize_bilinear(z, (round(z.shape[0] * dy / c), round(z.shape[1] * dx / c)))
        x, y = x[0] + c * np.arange(z.shape[1]), y[0] + c * np.arange(z.shape[0])
        dx = dy = c
    shade = LightSource(azdeg=315, altdeg=45).hillshade(z, vert_exag=3.0, dx=dx, dy=dy)
    grey = (255 * (0.35 + 0.65 * shade)).astype(np.uint8)
    rgba = np.stack([grey, grey, grey, np.full_like(grey, 255)], axis=-1)
    rgba[~np.isfinite(z)] = 0
    alt = ((ctx.world or ctx.summary.get("world") or {}).get("origin") or {}).get("alt")
    known = isinstance(alt, (int, float)) and np.isfinite(alt)
    r = Raster(rgba, float(x[0]) - dx / 2, float(y[0]) - dy / 2, dx, values=z + (float(alt) if known else 0.0),
               label="ground" if known else "ground, world z", unit="m", digits=2, smooth=True,
               values_px=HOVER_PX_TERRAIN)
    note = (f"hover: the ground's elevation, m (world z 0 = {float(alt):.2f} m)" if known else
            "hover: the ground's height, world z, m")
    return MapLayer("hillshade", "Terrain (hillshade)", raster=r, note=note)


def _read_band(path: Any, band: int = 1) -> np.ndarray:
    """A band of a GeoTIFF (row 0 north, as written) as floats with NaN for no data, flipped to row 0 south."""
    import rasterio

    with rasterio.open(path) as ds:
        a = ds.read(band).astype(np.float64)
        nod = ds.nodata
    if nod is not None:
        a[a == nod] = np.nan
    return np.flipud(a)


def deposition_layer(ctx: MapContext) -> MapLayer | None:
    """The application rate (L/ha) on the dose scale of fig. 23, with the asked rate and the dose bands marked."""
    from vinecli.report.deposition_plots import dose_scale

    doc = ctx.deposition
    if doc is None or not (ctx.run_dir / doc["geotiff"]["file"]).is_file():
        return None
    rate = _read_band(ctx.run_dir / doc["geotiff"]["file"])
    g = doc["grid"]
    nominal = (doc.get("metrics") or {}).get("nominal_rate_lpha")
    cmap, norm = dose_scale(nominal, rate)
    top = float(norm.vmax)
    shown = np.nan_to_num(rate) > WET_SHARE * top
    asked = float(nominal) if isinstance(nominal, (int, float)) and nominal > 0 else None
    dosed = bool((ctx.as_applied or {}).get("segments"))  # segment rates: no one asked rate, no dose bands
    r = Raster(_rgba(cmap, norm, rate, 0.85, shown), g["x0_m"], g["y0_m"], g["cell_m"],
               values=np.where(np.isfinite(rate), rate, np.nan), label="deposition", unit="L/ha", digits=1,
               ref=None if dosed else asked, ref_label="asked", values_px=HOVER_PX_DEPOSITION)
    bands = doc.get("dose_bands") or {}
    marks = {0.0: "0", top: f"{top:.3g}"}
    if dosed and asked is not None:
        marks[asked] = f"{asked:.3g} mean target"
    elif asked is not None:
        gap, hot = float(bands.get("gap_ratio", 0.6)), float(bands.get("hot_ratio", 1.3))
        marks |= {v: lab for v, lab in ((gap * asked, f"gap {gap:g}×"), (asked, f"{asked:.3g} asked"),
                                        (hot * asked, f"hot {hot:g}×")) if v < top}  # as fig. 23's colour bar
    return MapLayer("deposition", "Deposition, L/ha", raster=r, legend=scale_legend(cmap, norm, marks, "L/ha"),
                    note="hover: the cell's rate")


def canopy_layer(ctx: MapContext) -> MapLayer | None:
    """The spray budget's deposit on the canopy, µL per cm² of leaf (runs with a budget and a canopy)."""
    from matplotlib import colormaps
    from matplotlib.colors import Normalize

    b = ctx.budget
    if b is None or not (b.get("geotiff") or {}).get("file") or not (ctx.run_dir / b["geotiff"]["file"]).is_file():
        return None
    dep = _read_band(ctx.run_dir / b["geotiff"]["file"], 1)
    pos = dep[np.isfinite(dep) & (dep > 0)]
    if not pos.size:
        return None
    g = (b.get("maps") or {})["grid"]
    top = float(np.percentile(pos, 98))
    cmap, norm = colormaps["YlGn"], Normalize(0.0, top)
    r = Raster(_rgba(cmap, norm, dep, 0.9, np.nan_to_num(dep) > 0), g["x0_m"], g["y0_m"], g["cell_m"],
               values=np.where(np.nan_to_num(dep) > 0, dep, np.nan), label="canopy deposit", unit="µL/cm²",
               digits=3)
    legend = scale_legend(cmap, norm, {0.0: "0", top / 2: f"{top / 2:.2g}", top: f"{top:.2g}"}, "µL/cm² of leaf")
    return MapLayer("canopy", "Canopy deposit (budget)", raster=r, visible=False, legend=legend,
                    note="hover: the leaf deposit")
