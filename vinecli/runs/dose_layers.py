"""Small map layers of a dosed run for a web map (Leaflet), in the run directory's ``dose_map/``:

* ``prescription.geojson``, ``as_applied.geojson``, ``error.geojson``: one LineString per segment (RFC 7946,
  WGS84) with ``prescribed_lpha``; ``pump_lpha`` and ``deposit_lpha``; ``pump_error_pct`` and
  ``deposit_error_pct``, and a ``color`` (hex) of the layer's value on its scale;
* ``prescription.png``, ``as_applied.png``, ``error.png``: the same values painted on each segment's strip of
  ground (± half the row spacing), transparent elsewhere, north-up in longitude/latitude;
* ``overlays.json``: for each layer its files, the property shown, units, the colour scale (``vmin``, ``vmax``,
  ``cmap``) and the PNG's ``bounds`` [[south, west], [north, east]] (Leaflet's ``L.imageOverlay`` order).

Rates share one scale (0 to the highest prescribed or applied rate, viridis); errors a diverging one (±30 %,
RdBu: red over-, blue under-dosed).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.gis.canopy_out import segment_strip
from vinecli.gis.georef import Georef
from vinecli.gis.write import LocalFeature, write_features

__all__ = ["DOSE_MAP_DIR", "LAYERS", "write_dose_layers"]

DOSE_MAP_DIR = "dose_map"
ERROR_RANGE_PCT = 30.0
#: layer -> (property shown, units, colour map)
LAYERS = {"prescription": ("prescribed_lpha", "L/ha", "viridis"),
          "as_applied": ("pump_lpha", "L/ha", "viridis"),
          "error": ("pump_error_pct", "%", "RdBu_r")}


def _value(seg: dict[str, Any], prop: str) -> float:
    key = {"pump_error_pct": "pump_error", "deposit_error_pct": "deposit_error"}.get(prop, prop)
    v = seg.get(key)
    if not isinstance(v, (int, float)) or not math.isfinite(v):
        return math.nan
    return 100.0 * v if key != prop else float(v)


def _props(seg: dict[str, Any], layer: str) -> dict[str, Any]:
    base = {"row": seg["row"], "s0_m": seg["s0_m"], "s1_m": seg["s1_m"], "gap": int(seg["gap"])}
    names = {"prescription": ("prescribed_lpha",), "as_applied": ("pump_lpha", "deposit_lpha"),
             "error": ("pump_error_pct", "deposit_error_pct")}[layer]
    return {**base, **{n: (round(v, 3) if math.isfinite(v := _value(seg, n)) else None) for n in names}}


def write_dose_layers(out_dir: Path, segments: list[dict[str, Any]], spacing_m: float, georef: Georef) -> Path:
    """Write ``dose_map/`` (module docstring) into ``out_dir``; returns the folder."""
    import matplotlib

    folder = out_dir / DOSE_MAP_DIR
    folder.mkdir(parents=True, exist_ok=True)
    rates = [_value(s, p) for s in segments for p in ("prescribed_lpha", "pump_lpha")]
    top = max((r for r in rates if math.isfinite(r)), default=1.0) or 1.0
    rings = [segment_strip(tuple(s["start_enu"]), tuple(s["end_enu"]), 0.5 * spacing_m) for s in segments]
    flat = georef.to_lonlat([p for r in rings for p in r])  # one transformation for every corner
    strips = [flat[4 * k:4 * k + 4] for k in range(len(rings))]
    label, bounds = _labels(strips)
    entries = []
    for name, (prop, units, cmap_name) in LAYERS.items():
        vmin, vmax = (-ERROR_RANGE_PCT, ERROR_RANGE_PCT) if units == "%" else (0.0, top)
        cmap = matplotlib.colormaps[cmap_name]
        vals = np.array([_value(s, prop) for s in segments])
        rgba = np.zeros((len(segments) + 1, 4), dtype=np.uint8)  # label 0: transparent
        rgba[1:] = np.round(255 * cmap(np.clip((np.nan_to_num(vals) - vmin) / (vmax - vmin), 0.0, 1.0))).astype(np.uint8)
        rgba[1:, 3] = np.where(np.isfinite(vals), 255, 0)
        feats = [LocalFeature("LineString", [tuple(s["start_enu"]), tuple(s["end_enu"])],
                              {**_props(s, name), "color": "#{:02x}{:02x}{:02x}".format(*c[:3]) if c[3] else "#808080"})
                 for s, c in zip(segments, rgba[1:], strict=True)]
        write_features(folder / f"{name}.geojson", feats, georef, layer=name)
        _png(folder / f"{name}.png", rgba[label])
        entries.append({"name": name, "geojson": f"{name}.geojson", "png": f"{name}.png", "property": prop,
                        "units": units, "vmin": vmin, "vmax": vmax, "cmap": cmap_name, "bounds": bounds})
    (folder / "overlays.json").write_text(json.dumps({"schema": "vinecli.dose_map/1", "layers": entries}, indent=1),
                                          encoding="utf-8")
    return folder


def _labels(strips: list[list[tuple[float, float]]], px: int = 800) -> tuple[np.ndarray, list[list[float]]]:
    """Each pixel's strip (1-based, 0 none) on a north-up longitude/latitude grid over the strips, at most ``px``
    pixels on a side, square on the ground; the grid's [[S, W], [N, E]] bounds."""
    from rasterio.features import rasterize
    from rasterio.transform import from_bounds
    from shapely.geometry import Polygon

    pts = [p for s in strips for p in s] or [(0.0, 0.0), (1e-6, 1e-6)]
    w, e = min(p[0] for p in pts), max(p[0] for p in pts)
    s_, n = min(p[1] for p in pts), max(p[1] for p in pts)
    width_m = (e - w) * 111_320.0 * math.cos(math.radians(0.5 * (s_ + n)))
    height_m = (n - s_) * 110_540.0
    scale = px / max(width_m, height_m, 1e-9)
    nx, ny = max(int(round(width_m * scale)), 8), max(int(round(height_m * scale)), 8)
    label = rasterize(((Polygon(r), k + 1) for k, r in enumerate(strips)), out_shape=(ny, nx),
                      transform=from_bounds(w, s_, e, n, nx, ny), fill=0, dtype="int32") if strips else \
        np.zeros((ny, nx), dtype=np.int32)
    return label, [[s_, w], [n, e]]


def _png(path: Path, rgba: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(rgba, "RGBA").save(path, optimize=False)
