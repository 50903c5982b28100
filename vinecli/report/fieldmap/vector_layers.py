"""The vector layers of the field map, one small function each (a :class:`MapContext` -> a :class:`MapLayer` or
None): the rows (targeted ones marked, with their dose), the field, the geofence, the no-spray zones and the flown
path by phase or by sprayer on/off. World ENU metres; hover texts in the units a grower reads (L/ha, %, s)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vinecli.report.fieldmap.context import MapContext
from vinecli.report.fieldmap.map_model import Legend, LocalFeature, MapLayer

__all__ = ["PHASE_COLOURS", "fence_layer", "field_layer", "no_spray_layer", "path_phase_layer", "simplified_line",
           "path_sprayer_layer", "rows_layer", "sprayer_on"]

C_ROW, C_TARGET, C_FENCE, C_ZONE, C_FIELD = "#9ccc65", "#2e7d32", "#d62728", "#ef6c00", "#5d4037"
#: phase type -> colour of the flown path
PHASE_COLOURS = {"takeoff": "#1f77b4", "hold": "#9467bd", "goto": "#ff7f0e", "waypoints": "#ff7f0e",
                 "spray": "#00897b", "sprayer": "#00897b", "land": "#8c564b", "rtl": "#e377c2",
                 "open_loop": "#17becf"}
#: the sprayer counts as on from this share of the run's peak flow (as ``gis export``'s passes)
ON_SHARE = 0.05
SIMPLIFY_M = 0.05  # path simplification tolerance, m


def _pct(v: Any) -> str:
    return f"{100 * v:.0f} %" if isinstance(v, (int, float)) and math.isfinite(v) else "n/a"


def _same_row(a: list[tuple[float, float]], b: list[tuple[float, float]], tol_m: float = 0.05) -> bool:
    """Two polylines with the same ends (either way round)."""
    ends = np.array([a[0], a[-1]]), np.array([b[0], b[-1]])
    return bool(np.abs(ends[0] - ends[1]).max() <= tol_m or np.abs(ends[0] - ends[1][::-1]).max() <= tol_m)


def rows_layer(ctx: MapContext) -> MapLayer | None:
    """Every vine row (thin), the targeted ones (thick) with their mean rate, coverage and dose faults."""
    rows = ctx.rows
    dep = ctx.deposition or {}
    targeted = [(ctx.row_name(r), [(float(p[0]), float(p[1])) for p in r["polyline_enu"]], r)
                for r in dep.get("rows") or [] if len(r.get("polyline_enu") or []) >= 2]
    nominal = (dep.get("metrics") or {}).get("nominal_rate_lpha")
    if not rows and not targeted:
        return None
    feats = []
    for i, r in enumerate(rows):
        if any(_same_row(r, line) for _n, line, _d in targeted):
            continue
        length = float(np.hypot(*np.diff(np.asarray(r), axis=0).T).sum())
        feats.append(LocalFeature("LineString", r, {"row": i, "tip": f"row {i}: {length:.1f} m, not targeted"}))
    for name, line, d in targeted:
        mean = d.get("mean_rate_lpha")
        ok = isinstance(mean, (int, float)) and math.isfinite(mean)
        ratio = f" ({mean / nominal:.2f}× asked)" if ok and isinstance(nominal, (int, float)) and nominal > 0 else ""
        tip = (f"row {name} (targeted): mean {mean:.1f} L/ha{ratio}, covered {_pct(d.get('covered_fraction'))}"
               if ok else f"row {name} (targeted)")
        faults = d.get("faults") or []
        if faults:
            tip += "; " + ", ".join(f"{f['kind']} {f['from_m']:.1f}-{f['to_m']:.1f} m ({f['ratio']:.2f}×)"
                                    for f in faults[:4])
        feats.append(LocalFeature("LineString", line, {"row": name, "targeted": True, "tip": tip,
                                                       "style": {"color": C_TARGET, "weight": 2.5, "opacity": 0.8}}))
    sw = [(C_ROW, "vine row", "line")] + ([(C_TARGET, "targeted row (hover: its dose)", "line")] if targeted else [])
    return MapLayer("rows", "Vine rows", feats, style={"color": C_ROW, "weight": 1.5, "opacity": 0.8},
                    legend=Legend(swatches=sw))


def _row_spacing(ctx: MapContext, rows: list[list[tuple[float, float]]]) -> float:
    canopy = ((ctx.budget or {}).get("conditions") or {}).get("canopy") or {}
    if isinstance(canopy.get("spacing_m"), (int, float)):
        return float(canopy["spacing_m"])
    mids = np.array([np.mean(np.asarray(r), axis=0) for r in rows])
    if len(mids) < 2:
        return 1.0
    d = np.hypot(*(mids[:, None, :] - mids[None, :, :]).transpose(2, 0, 1))
    d[d == 0] = np.inf
    return float(np.median(d.min(axis=1)))


def field_layer(ctx: MapContext) -> MapLayer | None:
    """The field as the spray budget counts it (the rows' hull grown by half a row spacing: in / off the field)."""
    rows = ctx.rows
    if not rows:
        return None
    from vinecli.spray.drift import field_polygon

    geom: Any = field_polygon(rows, _row_spacing(ctx, rows), np.zeros((0, 2)), 0.5)
    if geom is None:
        return None
    ring = [(float(x), float(y)) for x, y in list(geom.exterior.coords)[:-1]]
    tip = f"field: {geom.area / 1e4:.3f} ha (the rows grown by half a row spacing; the budget's in / off the field)"
    return MapLayer("field", "Field boundary", [LocalFeature("Polygon", ring, {"tip": tip})],
                    style={"color": C_FIELD, "weight": 2, "fill": False, "dashArray": "2 4"},
                    legend=Legend(swatches=[(C_FIELD, "field (rows' hull)", "dash")]))


def fence_layer(ctx: MapContext) -> MapLayer | None:
    """The geofence polygon with its action and ceiling."""
    fence = ctx.fence
    if len(fence) < 3:
        return None
    g = (ctx.summary.get("world") or {}).get("geofence") or ctx.world.get("geofence") or {}
    src = (((ctx.world.get("gis") or {}).get("files") or {}).get("fence") or {}).get("path")
    tip = f"geofence: action {g.get('action', '?')}, ceiling {g.get('max_altitude_agl_m', '-')} m above ground" + \
        (f" (from {src})" if src else "")
    return MapLayer("fence", "Geofence", [LocalFeature("Polygon", fence, {"tip": tip})],
                    style={"color": C_FENCE, "weight": 2, "fill": False, "dashArray": "8 6"},
                    legend=Legend(swatches=[(C_FENCE, "geofence", "dash")]))


def no_spray_layer(ctx: MapContext) -> MapLayer | None:
    """The grower's no-spray zones (grown by their buffer)."""
    zones = (ctx.world.get("gis") or {}).get("no_spray_enu") or []
    if not zones:
        return None
    feats = [LocalFeature("Polygon", [(float(p[0]), float(p[1])) for p in z], {"tip": f"no-spray zone {k + 1}"})
             for k, z in enumerate(zones) if len(z) >= 3]
    return MapLayer("no_spray", "No-spray zones", feats,
                    style={"color": C_ZONE, "weight": 2, "fillColor": C_ZONE, "fillOpacity": 0.25},
                    legend=Legend(swatches=[(C_ZONE, "no-spray zone", "fill")]))


def _runs_of(labels: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) index ranges of equal consecutive labels."""
    if not labels.size:
        return []
    cut = np.flatnonzero(labels[1:] != labels[:-1]) + 1
    edges = [0, *cut.tolist(), labels.size]
    return list(zip(edges[:-1], edges[1:], strict=True))


def simplified_line(x: np.ndarray, y: np.ndarray) -> list[tuple[float, float]]:
    from shapely.geometry import LineString

    pts = np.column_stack([x, y])
    pts = pts[np.isfinite(pts).all(axis=1)]
    if len(pts) < 2:
        return []
    simple = LineString(pts).simplify(SIMPLIFY_M, preserve_topology=False)
    return [(round(float(a), 3), round(float(b), 3)) for a, b in simple.coords]


def _path_pieces(ctx: MapContext, labels: np.ndarray) -> list[tuple[int, float, float, list[tuple[float, float]]]]:
    """(label, t0, t1, line) per stretch of the path with one label (each stretch joined to the next)."""
    c = ctx.cols
    t, x, y = c["t_s"], c["pos_enu_x_m"], c["pos_enu_y_m"]
    out = []
    for a, b in _runs_of(labels):
        e = min(b + 1, t.size)  # share the next stretch's first point: no holes
        line = simplified_line(x[a:e], y[a:e])
        if line:
            out.append((int(labels[a]), float(t[a]), float(t[e - 1]), line))
    return out


def _phases(ctx: MapContext) -> dict[int, str]:
    return {int(e["data"]["index"]): str(e["data"].get("type", "?")) for e in ctx.events
            if e.get("kind") == "phase" and isinstance(e.get("data"), dict) and "index" in e["data"]}


def path_phase_layer(ctx: MapContext) -> MapLayer | None:
    """The flown path coloured by the mission phase it flew."""
    c = ctx.cols
    if "pos_enu_x_m" not in c or c["t_s"].size < 2:
        return None
    idx = np.nan_to_num(c.get("phase_index", np.zeros(c["t_s"].size)), nan=-1).astype(int)
    types = _phases(ctx)
    feats, seen = [], {}
    for k, t0, t1, line in _path_pieces(ctx, idx):
        kind = types.get(k, "before / after the mission" if k < 0 else "?")
        colour = PHASE_COLOURS.get(kind, "#757575")
        seen[kind] = colour
        feats.append(LocalFeature("LineString", line, {"phase": k, "tip": f"phase {k} ({kind}): {t0:.1f}-{t1:.1f} s",
                                                       "style": {"color": colour}}))
    return MapLayer("path_phase", "Flown path, by phase", feats, style={"weight": 2.5, "opacity": 0.9},
                    visible=sprayer_on(ctx) is None,  # a run that sprayed opens on its sprayer on / off
                    legend=Legend(swatches=[(col, kind, "line") for kind, col in seen.items()]))


def sprayer_on(ctx: MapContext) -> np.ndarray | None:
    """Per sample: the sprayer on (flow at least :data:`ON_SHARE` of the run's peak); None without a flow column."""
    q = ctx.cols.get("tank_flow_lps")
    if q is None or not np.isfinite(q).any() or float(np.nanmax(q)) <= 0:
        return None
    q = np.nan_to_num(q)
    return (q > 0) & (q >= ON_SHARE * float(q.max()))


def path_sprayer_layer(ctx: MapContext) -> MapLayer | None:
    """The flown path, black where the sprayer was on, grey where it was off (runs that sprayed)."""
    on = sprayer_on(ctx)
    if on is None or "pos_enu_x_m" not in ctx.cols:
        return None
    q = np.nan_to_num(ctx.cols["tank_flow_lps"])
    feats = []
    t = ctx.cols["t_s"]
    for k, t0, t1, line in _path_pieces(ctx, on.astype(int)):
        sel = (t >= t0) & (t < t1)
        vol = float(np.sum(q[sel][:-1] * np.diff(t[sel]))) if sel.sum() > 1 else 0.0
        tip = (f"sprayer on {t0:.1f}-{t1:.1f} s: {vol:.3f} L" if k else f"sprayer off {t0:.1f}-{t1:.1f} s")
        feats.append(LocalFeature("LineString", line, {"on": bool(k), "tip": tip, "style": {
            "color": "#000000" if k else "#9e9e9e", "weight": 3.5 if k else 1.5}}))
    return MapLayer("path_sprayer", "Flown path, sprayer on / off", feats, style={"opacity": 0.9},
                    legend=Legend(swatches=[("#000000", "sprayer on", "line"), ("#9e9e9e", "sprayer off", "line")]))
