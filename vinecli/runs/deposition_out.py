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
from typing import TYPE_CHECKING, Any

import numpy as np

from vinecli.missions.deposition_metrics import deposition_metrics, no_spray_fraction
from vinecli.rows.spray_rate import nominal_rate_lpha, phase_plan, spray_pattern, spray_swath_m
from vinecli.specs.mission import MissionSpec, SprayPhase
from vinecli.specs.vehicle import VehicleSpec

if TYPE_CHECKING:
    from vinecli.sim.spray_deposit import DepositionResult

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


def write_deposition(out_dir: Path, dep: DepositionResult, world: Any, crs: Any, doc: dict[str, Any]) -> None:
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


def _treated_area_ha(plan: Any, rows: list[list[tuple[float, float]]]) -> float:
    """Area the plan treats, ha: each row's planned stretch x the row spacing (one row: x the plan's track width)."""
    from vinecli.rows.detect import row_spacing_m

    if plan is None or not plan.stretches:
        return math.nan
    spacing = row_spacing_m(rows) if len(rows) >= 2 else plan.flow_width_m
    holes = sum(b - a for h in plan.holes.values() for a, b in h)
    return (sum(b - a for a, b in plan.stretches.values()) - holes) * spacing / 1e4


def world_row(phase: SprayPhase | None, i: int) -> int | None:
    """The world's index of the phase's ``i``-th target row (None for rows the phase gives as polylines)."""
    if phase is None or phase.rows == "world":
        return i
    listed = phase.rows[i] if i < len(phase.rows) else None
    return listed if isinstance(listed, int) else None


def _repeated(phase: SprayPhase | None, plan: Any, dep: DepositionResult, rows: list[list[tuple[float, float]]]
              ) -> list[np.ndarray] | None:
    """The passes over each 0.5 m piece of every row (:mod:`vinecli.missions.repeat_passes`) of a phase that repeats
    its passes until the tank is empty and flies one pass over each row; None otherwise (each row once: judged
    whole, so a row sprayed twice by mistake stays a hot spot)."""
    from vinecli.missions.repeat_passes import passes_per_piece

    lay = plan.layout if plan is not None else None
    if phase is None or phase.until != "empty" or lay is None or lay.mode == "broadcast":
        return None
    return passes_per_piece(dep.parcels.path_xy, rows, 0.5 * plan.flow_width_m, 0.5)


def evaluate_deposition(dep: DepositionResult, spec: MissionSpec, vehicle: VehicleSpec, world: Any,
                        rows: list[list[tuple[float, float]]], fence: Any) -> tuple[dict[str, float], dict[str, Any]]:
    """(summary metrics, deposition.json document) of one run's deposition (:func:`write_deposition` adds
    the raster's figures: ``totals.max_rate_lpha``, ``geotiff``). ``spec``: the mission as flown (spray rates
    resolved, :attr:`~vinecli.sim.setup.PreparedRun.flight`); the spray phase's plan gives each row's planned
    stretch and the track width."""
    phase = next((p for p in spec.phases if isinstance(p, SprayPhase)), None)
    polygon = getattr(fence, "polygon_enu", None) if fence is not None else None
    canopy = float(getattr(world, "canopy_width_m", 0.6))
    plan = None
    terrain = getattr(world, "terrain", None)
    bounds = tuple(terrain.bounds) if terrain is not None else None
    rho = float(getattr(world, "air_density", 1.225))
    if phase is not None and rows:
        plan = phase_plan(phase, vehicle, rows, rows[0][0], fence_enu=polygon, terrain_bounds=bounds, air_density=rho,
                          no_spray=getattr(world, "no_spray_enu", ()))
    nominal = nominal_rate_lpha(phase, vehicle, plan) if phase is not None and plan is not None else math.nan
    swath = spray_swath_m(vehicle, phase.height_agl_m) if phase is not None else math.nan
    all_rows = [[tuple(q) for q in r] for r in getattr(world, "vine_rows_enu", []) or []] or rows
    dose = spec.dose
    metrics, profiles = deposition_metrics(dep, rows, canopy, polygon, nominal, canopy_rows=all_rows,
                                           stretches=plan.stretches if plan is not None else None,
                                           window_m=dose.window_m, bands=(dose.gap_ratio, dose.hot_ratio),
                                           tolerance=dose.rate_tolerance, holes=plan.holes if plan is not None else None,
                                           passes=_repeated(phase, plan, dep, rows))
    metrics["spray_swath_m"] = swath
    metrics["spray_track_width_m"] = plan.flow_width_m if plan is not None else math.nan
    pattern = spray_pattern(vehicle, phase.height_agl_m, phase.speed_mps, rho) if phase is not None else None
    metrics["spray_effective_swath_m"] = pattern.effective_m if pattern is not None else math.nan
    metrics["treated_area_ha"] = _treated_area_ha(plan, rows)
    metrics["deposit_in_no_spray_fraction"] = no_spray_fraction(dep, getattr(world, "no_spray_enu", None) or [])
    lay = plan.layout if plan is not None else None
    sp = vehicle.sprayer
    doc = {
        "schema": "vinecli.deposition/2",
        "units": {"rate": "L/ha", "volume": "L", "length": "m", "frame": "world ENU"},
        "grid": {**dep.grid.to_dict(), "row0": "south"},
        "totals": {"emitted_l": dep.emitted_l, "on_grid_l": dep.on_grid_l, "off_grid_l": dep.off_grid_l,
                   "balance_error": dep.balance_error},  # + max_rate_lpha: write_deposition
        "spray_phase": None if phase is None else {
            "flow_lps": phase.flow_lps, "rate_lpha": nominal, "speed_mps": phase.speed_mps,
            "height_agl_m": phase.height_agl_m, "rate_given": phase.rate_lpha is not None,
            "litres_per_m": float(phase.flow_lps or 0.0) / phase.speed_mps, "swath_m": swath,
            "track_width_m": metrics["spray_track_width_m"], "effective_swath_m": metrics["spray_effective_swath_m"],
            "passes": None if lay is None else {"mode": lay.mode, "count": len(lay.across_m), "spacing_m": lay.spacing_m,
                                                "edge_offset_m": lay.edge_offset_m, "row_dose_expected": lay.row_dose}},
        "sprayer_law": {
            "flow": "speed-scaled (AC_Sprayer): litres per metre x ground speed, on above "
                    f"{sp.control.speed_min_mps:g} m/s after {sp.control.on_delay_s:g} s, off {sp.control.off_delay_s:g} s "
                    "below; sections open over the passes only" + (", ahead of the pass ends by the pump lag"
                                                                    if sp.control.section_lead else ""),
            "pump": {"tau_up_s": sp.pump.tau_up_s, "tau_down_s": sp.pump.tau_down_s,
                     "max_flow_lps": vehicle.tank.nozzle_max_flow_lps if vehicle.tank is not None else None},
            "nozzles": {"kind": sp.kind, "rated_flow_lps": sp.rated_flow_lps, "rated_pressure_bar": sp.rated_pressure_bar,
                        "pressure_range_bar": sp.pressure_range_bar,
                        "pressure_law": "q ∝ √p, VMD ∝ p^-n" if sp.pressure_law else "none (drop size fixed)",
                        "droplet_pressure_exponent": sp.droplet_pressure_exponent},
        },
        "dose_bands": dose.model_dump(mode="json"),
        "canopy_width_m": canopy,
        "geofence_polygon_enu": polygon,
        "sprayer": dep.sprayer,
        "model": {k: getattr(dep.config, k) for k in dep.config.__dataclass_fields__},
        "transport_s": dep.transport_s,
        "metrics": metrics,
        "path_enu": dep.parcels.path_xy[:: max(1, len(dep.parcels.path_xy) // 2000)],
        "rows": [{"row": p["row"], "length_m": p["length_m"], "planned_m": p["planned_m"],
                  "covered_fraction": p["covered_fraction"], "mean_rate_lpha": p["mean_rate_lpha"],
                  "sprayed_m": p["sprayed_m"], "not_judged_m": p["holes_m"], "segment_m": 0.5, "window_ratio": p["window_ratio"],
                  "in_band_fraction": p["in_band_fraction"],
                  "faults": p["faults"], "rate_lpha": p["rate_lpha"], "polyline_enu": rows[p["row"]],
                  **({"passes": p["passes"], "mean_rate_per_pass_lpha": p.get("mean_rate_per_pass_lpha")}
                     if "passes" in p else {})}
                 for p in profiles],
    }
    return metrics, doc
