"""A run back out to the grower's GIS: rows, passes, sprayed stretches and gaps, the deposition map, the fence and
no-spray zones of one run directory, as a GeoPackage (one layer each, EPSG:4326) or one RFC 7946 GeoJSON
(WGS84 longitude/latitude, a ``layer`` property per feature), through the georeference of the run's world
(:func:`vinecli.gis.georef.world_dir_georef`: the DSM's CRS for a world built from a DSM), so they open in
place over the DSM and ``deposition.tif``.

Layers (local figures in the properties: metres, seconds, L/ha):

* ``rows``: the rows the run targeted (``index``, ``length_m``, ``covered_fraction``, ``mean_rate_lpha``);
* ``passes``: the flown path while the sprayer was on (the flow at least :data:`ON_SHARE` of the run's peak: the
  pump's lag decays the flow for a while after the valve closes), one line per continuous stretch (``start_s``,
  ``end_s``, ``length_m``, ``volume_l``);
* ``sprayed`` / ``gaps``: stretches of each row that got at least / less than half the nominal rate (``row``,
  ``from_m``, ``to_m`` along the row, ``mean_rate_lpha``);
* ``deposition``: the application-rate map as polygons of rate classes (share of the nominal rate);
* ``fence``, ``no_spray``: the world's geofence polygon and no-spray zones (grown by their buffer).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError
from vinecli.gis.write import LocalFeature, write_layers
from vinecli.inputs import read_input_json
from vinecli.runs.deposition_out import DEPOSITION_JSON, DEPOSITION_TIF
from vinecli.runs.rundir import SUMMARY, TIMESERIES

__all__ = ["RATE_CLASSES", "export_run_gis", "run_layers"]

#: rate classes of the deposition layer: (label, low, high) as shares of the nominal rate
RATE_CLASSES = (("10-50 %", 0.1, 0.5), ("50-90 %", 0.5, 0.9), ("90-110 %", 0.9, 1.1), ("110-150 %", 1.1, 1.5),
                ("> 150 %", 1.5, float("inf")))


def export_run_gis(run_dir: Path | str, out: Path | str, *, overwrite: bool = False) -> Path:
    """Write the GIS layers of ``run_dir`` to ``out`` (``.gpkg`` or ``.geojson``); returns ``out``."""
    from vinecli.gis.georef import world_dir_georef
    from vinecli.output_guard import check_output_file

    run_dir, out = Path(run_dir), Path(out)
    if out.suffix.lower() not in (".gpkg", ".geojson", ".json"):
        raise InputError("GIS output must end in .gpkg or .geojson", path=out)
    summary = _read_json(run_dir / SUMMARY)
    world_dir = Path(str((summary.get("world") or {}).get("dir", "")))
    if not (world_dir / "world.json").is_file():
        raise InputError(f"the run's world {world_dir} is gone (its georeference is needed)", path=run_dir)
    world = _read_json(world_dir / "world.json")
    files = (world.get("gis") or {}).get("files") or {}
    sources = [f["path"] for f in (files.get("rows"), files.get("fence"), *files.get("no_spray", [])) if f]
    # the run, its world and the grower's GIS files the world was built from are inputs: never written over
    check_output_file(out, overwrite=overwrite, inputs=[run_dir, world_dir, *sources])
    layers = run_layers(run_dir, summary, world)
    return write_layers(out, layers, world_dir_georef(world_dir), overwrite=overwrite)


def _read_json(path: Path) -> dict[str, Any]:
    try:
        return dict(read_input_json(path, path.name))
    except InputError as exc:
        raise InputError(f"{exc.problem} (not a run directory?)" if "not found" in exc.problem else exc.problem,
                         path=path) from None
    except (TypeError, ValueError) as exc:
        raise InputError(f"cannot read: {exc}", path=path) from None


def run_layers(run_dir: Path, summary: dict[str, Any], world: dict[str, Any]) -> dict[str, list[LocalFeature]]:
    """The layers (see the module docstring) of one run, in the world's local metres."""
    dep = _read_json(run_dir / DEPOSITION_JSON) if (run_dir / DEPOSITION_JSON).is_file() else None
    rows_dep = {r["row"]: r for r in (dep or {}).get("rows", [])}
    rows = [[(float(x), float(y)) for x, y in r] for r in (summary.get("world") or {}).get("rows_enu") or []]
    layers: dict[str, list[LocalFeature]] = {"rows": [], "passes": _passes(run_dir), "sprayed": [], "gaps": [],
                                             "deposition": [], "fence": [], "no_spray": []}
    for i, r in enumerate(rows):
        d = rows_dep.get(i, {})
        layers["rows"].append(LocalFeature("LineString", r, {
            "index": i, "length_m": round(_length(r), 3), "covered_fraction": d.get("covered_fraction"),
            "mean_rate_lpha": d.get("mean_rate_lpha")}))
    nominal = float(((dep or {}).get("spray_phase") or {}).get("rate_lpha") or 0.0)
    for i, d in rows_dep.items():
        for kind, feats in _stretches(i, d, nominal):
            layers[kind] += feats
    if dep is not None and nominal > 0:
        layers["deposition"] = _rate_polygons(run_dir / DEPOSITION_TIF, dep["grid"], nominal)
    fence = (world.get("geofence") or {}).get("polygon_enu")
    if fence:
        layers["fence"].append(LocalFeature("Polygon", [tuple(p) for p in fence], {"action": world["geofence"].get("action")}))
    for z in ((world.get("gis") or {}).get("no_spray_enu") or []):
        layers["no_spray"].append(LocalFeature("Polygon", [tuple(p) for p in z], {}))
    return layers


def _length(line: list[tuple[float, float]]) -> float:
    a = np.asarray(line, float)
    return float(np.hypot(*np.diff(a, axis=0).T).sum()) if len(a) >= 2 else 0.0


#: the sprayer counts as on from this share of the run's peak flow
ON_SHARE = 0.05


def _passes(run_dir: Path) -> list[LocalFeature]:
    """The flown path while the sprayer was on (flow >= :data:`ON_SHARE` of the peak), one line per stretch."""
    from vinecli.runs.rundir import read_timeseries

    ts_path = run_dir / TIMESERIES
    if not ts_path.is_file():
        return []
    ts = read_timeseries(ts_path)
    if "tank_flow_lps" not in ts:
        return []
    t, x, y, q = (np.asarray(ts[k], float) for k in ("t_s", "pos_enu_x_m", "pos_enu_y_m", "tank_flow_lps"))
    q = np.nan_to_num(q)
    on = (q > 0) & (q >= ON_SHARE * float(q.max(initial=0.0)))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
    out = []
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if b - a < 2:
            continue
        line = list(zip(x[a:b].tolist(), y[a:b].tolist(), strict=True))
        vol = float(np.sum(q[a:b - 1] * np.diff(t[a:b])))
        out.append(LocalFeature("LineString", line, {"index": len(out), "start_s": round(float(t[a]), 3),
                                                     "end_s": round(float(t[b - 1]), 3),
                                                     "length_m": round(_length(line), 3), "volume_l": round(vol, 5)}))
    return out


def _stretches(i: int, d: dict[str, Any], nominal: float) -> list[tuple[str, list[LocalFeature]]]:
    """Row ``i``'s sprayed stretches (rate >= half the nominal) and gaps, from deposition.json's profile."""
    from shapely.geometry import LineString
    from shapely.ops import substring

    rate = np.array([np.nan if v is None else v for v in d.get("rate_lpha", [])], float)
    line = LineString(d["polyline_enu"])
    if rate.size == 0 or nominal <= 0 or line.length <= 0:
        return []
    seg = float(d.get("segment_m", 0.5))
    ok = np.nan_to_num(rate) >= 0.5 * nominal
    out: dict[str, list[LocalFeature]] = {"sprayed": [], "gaps": []}
    edges = np.flatnonzero(np.diff(np.concatenate([[-1], ok.astype(int), [-1]])))
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        s0, s1 = a * seg, min(b * seg, line.length)
        piece = substring(line, s0, s1)
        if piece.length <= 0:
            continue
        r = rate[a:b]
        mean = float(np.nanmean(r)) if np.isfinite(r).any() else None
        out["sprayed" if ok[a] else "gaps"].append(LocalFeature(
            "LineString", [(float(px), float(py)) for px, py in piece.coords],
            {"row": i, "from_m": round(s0, 3), "to_m": round(s1, 3),
             "mean_rate_lpha": None if mean is None else round(mean, 2)}))
    return list(out.items())


def _rate_polygons(tif: Path, grid: dict[str, Any], nominal: float) -> list[LocalFeature]:
    """The deposition map as polygons of :data:`RATE_CLASSES` (grid cells in the world's local metres)."""
    import rasterio
    from rasterio.features import shapes
    from rasterio.transform import Affine

    if not tif.is_file():
        return []
    with rasterio.open(tif) as ds:
        rate = ds.read(1, masked=True).filled(np.nan)
    cell, x0, y0, ny = float(grid["cell_m"]), float(grid["x0_m"]), float(grid["y0_m"]), int(grid["ny"])
    pix_enu = Affine(cell, 0.0, x0, 0.0, -cell, y0 + ny * cell)  # row 0 = north, as written
    share = np.nan_to_num(rate) / nominal
    cls = np.zeros(share.shape, np.int32)
    for k, (_, lo, hi) in enumerate(RATE_CLASSES, start=1):
        cls[(share >= lo) & (share < hi)] = k
    out = []
    for geom, k in shapes(cls, mask=cls > 0, transform=pix_enu):
        label, lo, hi = RATE_CLASSES[int(k) - 1]
        ring, *holes = ([(float(px), float(py)) for px, py in r[:-1]] for r in geom["coordinates"])
        props = {"rate_class": label, "min_rate_lpha": round(lo * nominal, 2),
                 "max_rate_lpha": None if hi == float("inf") else round(hi * nominal, 2)}
        out.append(LocalFeature("Polygon", ring, props, holes))
    return out
