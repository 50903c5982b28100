"""The dose layers of the field map, for a run that flew segment rates (a canopy dose or a prescription map), read
from its ``as_applied.json`` (docs/dose.md "As applied"): each canopy segment painted on its strip of ground (± half
the row spacing), world ENU metres.

* the dose error per segment (the pump's rate against the segment's target, ±30 % on a diverging scale, as fig. 26);
  hover: the target, what the pump applied and what reached the canopy band, with their errors;
* the prescription zones (a map's distinct rates, or a dose expression's rate classes), outlined; hover (the
  outline): the zone's errors and its share of sprayed length within the tolerance;
* the prescription and the as-applied rate on one scale (L/ha), hover: the segment's rate;
* the canopy segments (their leaf-wall height; gaps in red); hover: wall height, width, leaf-wall area.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vinecli.report.dose_plots import ERROR_RANGE_PCT
from vinecli.report.fieldmap.context import MapContext
from vinecli.report.fieldmap.map_model import Legend, LocalFeature, MapLayer

__all__ = ["canopy_segments_layer", "dose_error_layer", "dose_zones_layer", "prescription_layer",
           "as_applied_layer"]

C_GAP = "#d62728"


def _doc(ctx: MapContext) -> dict[str, Any] | None:
    """The run's as_applied.json when it has segments, else None."""
    doc = ctx.as_applied
    return doc if doc and doc.get("segments") else None


def _num(v: Any) -> float:
    return float(v) if isinstance(v, (int, float)) and math.isfinite(v) else math.nan


def _half_spacing(doc: dict[str, Any]) -> float:
    from vinecli.report.dose_plots import strip_half_width

    return strip_half_width(doc)


def _strip(g: dict[str, Any], half: float) -> list[tuple[float, float]]:
    from vinecli.gis.canopy_out import segment_strip

    return segment_strip((float(g["start_enu"][0]), float(g["start_enu"][1])),
                         (float(g["end_enu"][0]), float(g["end_enu"][1])), half)


def _hex(rgba: Any) -> str:
    return "#{:02x}{:02x}{:02x}".format(*(int(round(255 * float(c))) for c in rgba[:3]))


def _pct(v: float) -> str:
    return f"{v:+.1f} %" if math.isfinite(v) else "-"


def _row_names(ctx: MapContext) -> dict[Any, Any]:
    """The phase's row index (a segment's ``row``) -> the row's name on the map (the deposition's rows, in the
    same order: the world's row number when the mission named world rows)."""
    return {r["row"]: ctx.row_name(r) for r in (ctx.deposition or {}).get("rows") or []}


def _where(g: dict[str, Any], names: dict[Any, Any]) -> str:
    return f"row {names.get(g['row'], g['row'])}, {g['s0_m']:.1f}-{g['s1_m']:.1f} m"


def segment_tip(g: dict[str, Any], names: dict[Any, Any]) -> str:
    """A segment's hover text: where it is, its target, what the pump applied and what reached the canopy."""
    target, pump, dep = _num(g.get("prescribed_lpha")), _num(g.get("pump_lpha")), _num(g.get("deposit_lpha"))
    head = _where(g, names)
    if g.get("gap") or not target > 0:
        return f"{head}: gap (no vines), target 0 L/ha, pump {pump:.1f} L/ha"
    text = (f"{head}: target {target:.1f} L/ha · applied (pump) {pump:.1f} L/ha "
            f"({_pct(100 * _num(g.get('pump_error')))})")
    if math.isfinite(dep):
        text += f" · on the canopy band {dep:.1f} L/ha ({_pct(100 * _num(g.get('deposit_error')))})"
    return text


def _rate_scale(doc: dict[str, Any]) -> tuple[Any, Any, float]:
    """(colour map, norm, top): 0 to the highest prescribed or applied rate, viridis (the dose map's scale)."""
    from matplotlib import colormaps
    from matplotlib.colors import Normalize

    rates = [_num(g.get(k)) for g in doc["segments"] for k in ("prescribed_lpha", "pump_lpha")]
    top = max((r for r in rates if math.isfinite(r)), default=1.0) or 1.0
    return colormaps["viridis"], Normalize(0.0, top), top


def _rate_layer(ctx: MapContext, key: str, name: str, prop: str, note: str) -> MapLayer | None:
    from vinecli.report.fieldmap.raster_layers import scale_legend

    doc = _doc(ctx)
    if doc is None:
        return None
    cmap, norm, top = _rate_scale(doc)
    half, names = _half_spacing(doc), _row_names(ctx)
    feats = []
    for g in doc["segments"]:
        v = _num(g.get(prop))
        if not math.isfinite(v):
            continue
        c = _hex(cmap(norm(v)))
        feats.append(LocalFeature("Polygon", _strip(g, half), {"tip": segment_tip(g, names),
                                                               "style": {"fillColor": c}}))
    legend = scale_legend(cmap, norm, {0.0: "0", top / 2: f"{top / 2:.3g}", top: f"{top:.3g}"}, "L/ha")
    return MapLayer(key, name, feats, style={"stroke": False, "fillOpacity": 0.85}, visible=False, legend=legend,
                    note=note)


def prescription_layer(ctx: MapContext) -> MapLayer | None:
    """Each segment's target rate (the prescription, or the dose expression on its canopy), L/ha."""
    return _rate_layer(ctx, "prescription", "Prescription (target), L/ha", "prescribed_lpha",
                       "hover: target vs applied")


def as_applied_layer(ctx: MapContext) -> MapLayer | None:
    """Each segment's rate as the pump applied it (flow / (ground speed x track width)), L/ha."""
    return _rate_layer(ctx, "as_applied", "As applied (pump), L/ha", "pump_lpha", "hover: target vs applied")


def dose_error_layer(ctx: MapContext) -> MapLayer | None:
    """Each segment's pump error against its target, % (red over-, blue under-dosed; gaps outlined in red)."""
    from matplotlib import colormaps
    from matplotlib.colors import Normalize

    from vinecli.report.fieldmap.raster_layers import scale_legend

    doc = _doc(ctx)
    if doc is None:
        return None
    cmap, norm = colormaps["RdBu_r"], Normalize(-ERROR_RANGE_PCT, ERROR_RANGE_PCT)
    half, names = _half_spacing(doc), _row_names(ctx)
    tol = 100 * _num(doc.get("tolerance"))
    feats = []
    for g in doc["segments"]:
        err = 100 * _num(g.get("pump_error"))
        if g.get("gap") or not math.isfinite(err):
            style = {"fillColor": "#ffffff", "fillOpacity": 0.3, "stroke": True, "color": C_GAP, "weight": 1}
        else:
            style = {"fillColor": _hex(cmap(norm(err)))}
        feats.append(LocalFeature("Polygon", _strip(g, half), {"tip": segment_tip(g, names), "style": style}))
    marks = {-ERROR_RANGE_PCT: f"-{ERROR_RANGE_PCT:g}", 0.0: "0", ERROR_RANGE_PCT: f"+{ERROR_RANGE_PCT:g} %"}
    if math.isfinite(tol) and 0 < tol < ERROR_RANGE_PCT:
        marks |= {-tol: f"-{tol:g}", tol: f"+{tol:g}"}
    legend = scale_legend(cmap, norm, marks, "applied / target - 1 (pump), %")
    legend.swatches = [(C_GAP, "gap: kept closed", "line")] if any(g.get("gap") for g in doc["segments"]) else []
    return MapLayer("dose_error", "Dose error per segment, %", feats, style={"stroke": False, "fillOpacity": 0.85},
                    legend=legend, note="hover: target vs applied, % error")


def dose_zones_layer(ctx: MapContext) -> MapLayer | None:
    """The prescription's zones (the segments of one rate, or of one rate class), outlined, with their errors."""
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    from vinecli.missions.as_applied import rate_zones

    doc = _doc(ctx)
    if doc is None:
        return None
    segs = [g for g in doc["segments"] if not g.get("gap") and _num(g.get("prescribed_lpha")) > 0]
    if not segs:
        return None
    zone, names = rate_zones([g["prescribed_lpha"] for g in segs])
    stats = {z.get("zone"): z for z in doc.get("zones") or []}
    cmap, norm, _top = _rate_scale(doc)
    half = _half_spacing(doc)
    feats, swatches = [], []
    for k, name in enumerate(names):
        mine = [Polygon(_strip(g, half * 1.001)) for g, z in zip(segs, zone, strict=True) if z == k]
        if not mine:
            continue
        rate = float(np.mean([g["prescribed_lpha"] for g, z in zip(segs, zone, strict=True) if z == k]))
        colour = _hex(cmap(norm(rate)))
        s = stats.get(name) or {}
        tip = (f"zone {name}: {_num(s.get('length_m')):.0f} m of row, applied (pump) "
               f"{_pct(100 * _num(s.get('pump_error')))}, on the canopy band {_pct(100 * _num(s.get('deposit_error')))}"
               f", {100 * _num(s.get('pump_in_band')):.0f} % of its length within ±{100 * _num(doc.get('tolerance')):g} %")
        geom = unary_union(mine)
        for part in getattr(geom, "geoms", [geom]):
            ring = [(float(x), float(y)) for x, y in list(part.exterior.coords)[:-1]]
            feats.append(LocalFeature("Polygon", ring, {"zone": name, "tip": tip,
                                                        "style": {"color": colour}}))
        swatches.append((colour, f"zone {name}", "dash"))
    # outlines only (no fill: the segments under them keep their hover), hovered on the line; a map's zones shown
    # when the page opens, a dose expression's rate classes (which alternate along a row) on demand
    a_map = bool((doc.get("summary") or {}).get("prescription"))
    return MapLayer("dose_zones", "Prescription zones" if a_map else "Rate classes (dose per canopy)", feats,
                    style={"weight": 3, "fill": False, "dashArray": "6 4"}, visible=a_map,
                    legend=Legend(swatches=swatches), note="hover its outline: the zone's error")


def canopy_segments_layer(ctx: MapContext) -> MapLayer | None:
    """The canopy segments the rates were set on (a line each, its leaf-wall height in its colour; gaps red)."""
    from matplotlib import colormaps
    from matplotlib.colors import Normalize

    from vinecli.report.fieldmap.raster_layers import scale_legend

    doc = _doc(ctx)
    if doc is None:
        return None
    heights = [_num(g.get("wall_height_m")) for g in doc["segments"] if not g.get("gap")]
    top = max((h for h in heights if math.isfinite(h)), default=0.0)
    cmap, norm = colormaps["YlGn"], Normalize(0.0, top or 1.0)
    names = _row_names(ctx)
    feats = []
    for g in doc["segments"]:
        h, w, lwa = _num(g.get("wall_height_m")), _num(g.get("width_m")), _num(g.get("lwa_m2pha"))
        line = [(float(g["start_enu"][0]), float(g["start_enu"][1])), (float(g["end_enu"][0]), float(g["end_enu"][1]))]
        head = _where(g, names)
        if g.get("gap"):
            feats.append(LocalFeature("LineString", line, {"tip": f"{head}: gap (missing vines)",
                                                           "style": {"color": C_GAP, "dashArray": "3 3"}}))
            continue
        tip = f"{head}: wall {h:.2f} m high, {w:.2f} m wide" + (f", LWA {lwa:,.0f} m²/ha" if math.isfinite(lwa) else "")
        feats.append(LocalFeature("LineString", line, {"tip": tip, "style": {
            "color": _hex(cmap(norm(h))) if math.isfinite(h) else "#9e9e9e"}}))
    legend = scale_legend(cmap, norm, {0.0: "0", top: f"{top:.2g} m"}, "leaf-wall height, m") if top > 0 else None
    if legend is not None and any(g.get("gap") for g in doc["segments"]):
        legend.swatches = [(C_GAP, "gap (missing vines)", "dash")]
    return MapLayer("canopy_segments", "Canopy segments", feats, style={"weight": 4, "opacity": 0.9}, visible=False,
                    legend=legend, note="hover: wall height, width, leaf-wall area")
