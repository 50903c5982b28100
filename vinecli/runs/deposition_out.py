"""Deposition outputs of a spray run: ``deposition.tif``, ``deposition.json`` and the summary metrics.

``deposition.tif``: float32 application rate, L/ha, one band, north-up, nodata -9999 off the
terrain. Worlds built from a DSM with a CRS: georeferenced in that CRS (an affine transform with
rotation terms maps the ENU grid onto the projected CRS through the geodetic origin, exact to
the CRS's scale-factor change over the field, < 1 mm over 100 m). Other worlds: no CRS; the raster
coordinates are the world's ENU metres, and the tags carry the geodetic origin (``ORIGIN_LAT``,
``ORIGIN_LON``, ``ORIGIN_ALT``) and ``FRAME=ENU``. ``deposition.json`` (schema
``vinecli.deposition/1``): grid, totals, model options, sprayer, per-row figures.
"""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.missions.deposition_metrics import deposition_metrics
from vinecli.rows.spray_rate import flow_for_rate, nominal_rate_lpha, spray_swath_m, track_width_m
from vinecli.specs.mission import MissionSpec, SprayPhase
from vinecli.specs.vehicle import VehicleSpec

__all__ = ["DEPOSITION_JSON", "DEPOSITION_TIF", "NODATA", "clean_json", "dsm_crs", "evaluate_deposition",
           "write_deposition", "write_grid_tif"]

log = logging.getLogger(__name__)

DEPOSITION_TIF = "deposition.tif"
DEPOSITION_JSON = "deposition.json"
NODATA = -9999.0


def dsm_crs(world_dir: Path) -> Any:
    """The CRS of the DSM a world was built from (rasterio CRS), or None (flat world, DSM without CRS)."""
    try:
        doc = json.loads((Path(world_dir) / "world.json").read_text(encoding="utf-8"))
        src = (doc.get("terrain") or {}).get("source") or {}
        if src.get("type") != "dsm":
            return None
        import rasterio

        with rasterio.open(src["dsm"]) as ds:
            return ds.crs
    except (OSError, KeyError, ValueError, json.JSONDecodeError) as exc:
        log.info("no DSM CRS for the deposition map of %s: %s", world_dir, exc)
        return None
    except Exception as exc:  # noqa: BLE001 - rasterio errors: fall back to the local grid
        log.info("no DSM CRS for the deposition map of %s: %s", world_dir, exc)
        return None


def _enu_to_crs_affine(origin: Any, crs: Any) -> tuple[float, float, float, float, float, float]:
    """(a, b, c, d, e, f) with X = a e + b n + c, Y = d e + e' n + f from ENU (m) to the CRS, by 3 points."""
    from pyproj import Transformer

    tr = Transformer.from_crs("EPSG:4326", crs, always_xy=True)
    pts = [(0.0, 0.0), (100.0, 0.0), (0.0, 100.0)]
    xy = []
    for e, n in pts:
        lat, lon, _alt = origin.enu_to_geodetic(e, n, 0.0)
        xy.append(tr.transform(lon, lat))
    (x0, y0), (x1, y1), (x2, y2) = xy
    return ((x1 - x0) / 100.0, (x2 - x0) / 100.0, x0, (y1 - y0) / 100.0, (y2 - y0) / 100.0, y0)


def write_deposition(out_dir: Path, dep: Any, world: Any, crs: Any, doc: dict[str, Any]) -> None:
    """Write ``deposition.tif`` and ``deposition.json`` into ``out_dir``; the JSON is ``doc`` (of
    :func:`evaluate_deposition`) with ``totals.max_rate_lpha`` and ``geotiff`` filled in."""
    g = dep.grid
    rate_lpha = dep.rate_lpha()
    max_rate = float(np.nanmax(rate_lpha)) if dep.volume_l.size else 0.0
    transform = write_grid_tif(out_dir / DEPOSITION_TIF, g, [rate_lpha], ["application rate L/ha"], world, crs,
                               {"UNITS": "L/ha", "QUANTITY": "spray application rate"})
    doc = {**doc, "totals": {**doc["totals"], "max_rate_lpha": max_rate},
           "geotiff": {"file": DEPOSITION_TIF, "crs": crs.to_string() if crs is not None else None,
                       "transform": list(transform)[:6], "nodata": NODATA, "units": "L/ha"}}
    (out_dir / DEPOSITION_JSON).write_text(json.dumps(clean_json(doc), indent=1, allow_nan=False), encoding="utf-8")


def write_grid_tif(path: Path, g: Any, bands: list[np.ndarray], names: list[str], world: Any, crs: Any,
                   tags: dict[str, str]) -> Any:
    """Write float32 ``bands`` ((ny, nx) on the deposition grid ``g``, row 0 south, NaN = nodata) as a north-up
    GeoTIFF georeferenced as :data:`DEPOSITION_TIF` (see the module doc); returns its affine transform."""
    import rasterio
    from rasterio.transform import Affine

    # pixel (col, row) -> ENU: e = x0 + col cell, n = y_top - row cell
    y_top = g.y0 + g.ny * g.cell
    pix_enu = Affine(g.cell, 0.0, g.x0, 0.0, -g.cell, y_top)
    tags = {**tags, "ORIGIN_LAT": repr(world.origin.lat), "ORIGIN_LON": repr(world.origin.lon),
            "ORIGIN_ALT": repr(world.origin.alt)}
    if crs is not None:
        a, b, c, d, e, f = _enu_to_crs_affine(world.origin, crs)
        transform = Affine(a, b, c, d, e, f) * pix_enu
        tags["FRAME"] = f"{crs.to_string()} (ENU grid mapped through the origin)"
    else:
        transform = pix_enu
        tags["FRAME"] = "ENU (x east, y north, m from the geodetic origin)"
    profile = {"driver": "GTiff", "width": g.nx, "height": g.ny, "count": len(bands), "dtype": "float32",
               "nodata": NODATA, "transform": transform, "compress": "deflate", "tiled": False}
    if crs is not None:
        profile["crs"] = crs
    with rasterio.open(path, "w", **profile) as ds:
        for i, (band, name) in enumerate(zip(bands, names, strict=True), start=1):
            a = np.flipud(band).astype(np.float32)  # row 0 = north
            ds.write(np.where(np.isfinite(a), a, np.float32(NODATA)).astype(np.float32), i)
            ds.set_band_description(i, name)
        ds.update_tags(**tags)
    return transform


def clean_json(v: Any, digits: int | None = 6) -> Any:
    """``v`` made JSON-ready: numpy arrays and scalars as lists and numbers, floats rounded to ``digits``
    decimals (None: full precision), non-finite floats as null."""
    if isinstance(v, dict):
        return {k: clean_json(x, digits) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [clean_json(x, digits) for x in v]
    if isinstance(v, np.ndarray):
        return [clean_json(x, digits) for x in v.tolist()]
    if isinstance(v, (float, np.floating)):
        f = float(v)
        if not math.isfinite(f):
            return None
        return round(f, digits) if digits is not None else f
    if isinstance(v, np.integer):
        return int(v)
    return v


def evaluate_deposition(dep: Any, spec: MissionSpec, vehicle: VehicleSpec, world: Any,
                        rows: list[list[tuple[float, float]]], fence: Any) -> tuple[dict[str, float], dict[str, Any]]:
    """(summary metrics, deposition.json document) of one run's deposition (:func:`write_deposition` adds
    the raster's figures: ``totals.max_rate_lpha``, ``geotiff``)."""
    phase = next((p for p in spec.phases if isinstance(p, SprayPhase)), None)
    nominal = nominal_rate_lpha(phase, vehicle, rows) if phase is not None else math.nan
    swath = spray_swath_m(vehicle, phase.height_agl_m) if phase is not None else math.nan
    track = track_width_m(vehicle, phase, rows) if phase is not None else math.nan
    polygon = getattr(fence, "polygon_enu", None) if fence is not None else None
    canopy = float(getattr(world, "canopy_width_m", 0.6))
    all_rows = [[tuple(q) for q in r] for r in getattr(world, "vine_rows_enu", []) or []] or rows
    metrics, profiles = deposition_metrics(dep, rows, canopy, polygon, nominal, canopy_rows=all_rows)
    metrics["spray_swath_m"] = swath
    metrics["spray_track_width_m"] = track
    flow = float(phase.flow_lps) if phase is not None and phase.flow_lps is not None else (
        flow_for_rate(nominal, track, phase.speed_mps) if phase is not None else math.nan)
    doc = {
        "schema": "vinecli.deposition/1",
        "units": {"rate": "L/ha", "volume": "L", "length": "m", "frame": "world ENU"},
        "grid": {**dep.grid.to_dict(), "row0": "south"},
        "totals": {"emitted_l": dep.emitted_l, "on_grid_l": dep.on_grid_l, "off_grid_l": dep.off_grid_l,
                   "balance_error": dep.balance_error},  # + max_rate_lpha: write_deposition
        "spray_phase": None if phase is None else {"flow_lps": flow, "rate_lpha": nominal, "swath_m": swath,
                                                   "speed_mps": phase.speed_mps, "height_agl_m": phase.height_agl_m,
                                                   "rate_given": phase.rate_lpha is not None},
        "canopy_width_m": canopy,
        "geofence_polygon_enu": polygon,
        "sprayer": dep.sprayer,
        "model": {k: getattr(dep.config, k) for k in dep.config.__dataclass_fields__},
        "transport_s": dep.transport_s,
        "metrics": metrics,
        "path_enu": dep.parcels.path_xy[:: max(1, len(dep.parcels.path_xy) // 2000)],
        "rows": [{"row": p["row"], "length_m": p["length_m"], "covered_fraction": p["covered_fraction"],
                  "mean_rate_lpha": p["mean_rate_lpha"], "sprayed_m": p["sprayed_m"], "segment_m": 0.5,
                  "rate_lpha": p["rate_lpha"], "polyline_enu": rows[p["row"]]} for p in profiles],
    }
    return metrics, doc
