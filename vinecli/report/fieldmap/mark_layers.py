"""The marks of the field map: what happened where (sortie breakpoints, refills and battery swaps, failsafes, dose
faults, sprayer cut-outs, each with its time and cause) and where a failed check failed (the path during its
window, the rows or row stretches out of their dose band, the fence or the no-spray zones it is about)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vinecli.report.fieldmap.context import MapContext
from vinecli.report.fieldmap.map_model import Legend, LocalFeature, MapLayer

__all__ = ["events_layer", "failed_checks_layer", "locate_check"]

#: mark kind -> (colour, legend label, radius px)
MARKS = {"start": ("#2e7d32", "start", 5), "end": ("#212121", "end", 5), "breakpoint": ("#6a1b9a", "sortie breakpoint", 7), "service": ("#0d47a1", "refill / battery swap", 6),
         "failsafe": ("#d62728", "failsafe", 9), "hot": ("#b71c1c", "dose fault: hot spot", 7),
         "gap": ("#1565c0", "dose fault: gap", 7), "cutout": ("#ff8f00", "sprayer cut out", 6)}
C_FAILED = "#ff1744"


def _mark(kind: str, xy: Any, tip: str) -> LocalFeature | None:
    if xy is None or len(xy) < 2 or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in xy[:2]):
        return None
    colour, _label, radius = MARKS[kind]
    return LocalFeature("Point", [(float(xy[0]), float(xy[1]))], {"kind": kind, "tip": tip, "style": {
        "color": colour, "fillColor": colour, "radius": radius}})


def _point_along(line: list[Any], s: float) -> tuple[float, float]:
    pts = np.asarray(line, float)
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    s = min(max(s, 0.0), float(cum[-1]))
    return float(np.interp(s, cum, pts[:, 0])), float(np.interp(s, cum, pts[:, 1]))


def _row_lines(ctx: MapContext) -> dict[Any, list[Any]]:
    return {ctx.row_name(r): r["polyline_enu"] for r in (ctx.deposition or {}).get("rows") or []}


def events_layer(ctx: MapContext) -> MapLayer | None:
    """Sortie breakpoints, services, failsafes, dose faults and sprayer cut-outs as marks with time and cause."""
    from vinecli.runs.failsafes import describe_failsafe

    s = ctx.summary
    marks: list[LocalFeature | None] = []
    t = ctx.cols.get("t_s")
    if t is not None and t.size and "pos_enu_x_m" in ctx.cols:
        marks.append(_mark("start", ctx.position_at(float(t[0])), f"start at {float(t[0]):.1f} s"))
        marks.append(_mark("end", ctx.position_at(float(t[-1])), f"end at {float(t[-1]):.1f} s ({s.get('status')})"))
    sorties = s.get("sorties")
    for so in sorties[:-1] if isinstance(sorties, list) else []:
        marks.append(_mark("breakpoint", so.get("breakpoint_enu"), f"sortie {so.get('sortie')} ended at "
                           f"{so.get('t_end_s', float('nan')):.1f} s ({so.get('end_reason', '?')}): the next one "
                           "resumes here"))
    for e in ctx.events:
        if e.get("kind") in ("refill", "battery_swap"):
            what = "battery swap" if e["kind"] == "battery_swap" else "refill"
            marks.append(_mark("service", ctx.position_at(float(e["t_s"])),
                               f"{what} at {float(e['t_s']):.1f} s: {e.get('message', '')}"))
    for f in s.get("failsafes") or []:
        if isinstance(f, dict):
            marks.append(_mark("failsafe", f.get("position_enu"), describe_failsafe(f)
                               + (f": {f['detail']}" if f.get("detail") else "")))
    for f in s.get("dose_faults") or []:
        when = f.get("t_s")
        at = f" sprayed at {when:.1f} s" if isinstance(when, (int, float)) and math.isfinite(when) else ""
        marks.append(_mark("hot" if f.get("kind") == "hot" else "gap", f.get("position_enu"),
                           f"{f.get('kind')} on row {f.get('row')}, {f.get('from_m', 0):.1f}-{f.get('to_m', 0):.1f} m "
                           f"along it: {f.get('ratio', float('nan')):.2f}× the asked rate{at}"))
    lines = _row_lines(ctx)
    for c in s.get("sprayer_cutouts") or []:
        line = lines.get(c.get("row"))
        if line:
            marks.append(_mark("cutout", _point_along(line, float(c.get("at_m", 0.0))),
                               f"sprayer cut out at {float(c.get('t_s', 0)):.1f} s over row {c.get('row')}: "
                               f"{c.get('reason', '')}"))
    feats = [m for m in marks if m is not None]
    if not feats:
        return None
    kinds = dict.fromkeys(str(f.properties["kind"]) for f in feats)
    return MapLayer("events", "Events (time and cause)", feats, style={"weight": 2, "fillOpacity": 0.35},
                    legend=Legend(swatches=[(MARKS[k][0], MARKS[k][1], "dot") for k in kinds]))


def _path_between(ctx: MapContext, t0: float, t1: float) -> list[tuple[float, float]]:
    from vinecli.report.fieldmap.vector_layers import simplified_line

    c = ctx.cols
    if "pos_enu_x_m" not in c:
        return []
    sel = (c["t_s"] >= t0) & (c["t_s"] <= t1)
    return simplified_line(c["pos_enu_x_m"][sel], c["pos_enu_y_m"][sel])


def _substring(line: list[Any], a: float, b: float) -> list[tuple[float, float]]:
    from shapely.geometry import LineString
    from shapely.ops import substring

    piece = substring(LineString(line), a, b)
    return [(float(x), float(y)) for x, y in piece.coords] if piece.length > 0 else []


#: check quantity (substring) -> what it is about on the ground
_ROW_DOSE = ("row_rate_error", "mean_rate_lpha", "deposit_cv", "deposit_on_rows")


def locate_check(ctx: MapContext, check: dict[str, Any]) -> list[LocalFeature]:
    """Where a check failed on the field (local features, empty when it has no place): a row dose check its rows off
    the bound (the tolerance; else the worst row), a hot-spot / gap check its fault stretches, a coverage check its
    rows under half covered, a drift or no-spray check the fence or the zones, a status check its failsafes, any
    other check with a time window the path flown in it."""
    q = str(check.get("quantity", ""))
    dep = ctx.deposition or {}
    rows = [r for r in dep.get("rows") or [] if len(r.get("polyline_enu") or []) >= 2]
    nominal = (dep.get("metrics") or {}).get("nominal_rate_lpha") or 0.0
    tol = float((dep.get("dose_bands") or {}).get("rate_tolerance", 0.15))
    out: list[tuple[str, list[tuple[float, float]]]] = []
    if "dose_window_ratio" in q:
        kind = "hot" if q.endswith("max") else "gap"
        out = [("LineString", _substring(r["polyline_enu"], f["from_m"], f["to_m"])) for r in rows
               for f in r.get("faults") or [] if f.get("kind") == kind]
    elif "coverage" in q:
        out = [("LineString", r["polyline_enu"]) for r in rows if (r.get("covered_fraction") or 0.0) < 0.5]
    elif any(k in q for k in _ROW_DOSE) and nominal > 0:
        err = lambda r: abs(float(r.get("mean_rate_lpha") or 0.0) / nominal - 1.0)  # noqa: E731
        bound = check.get("bound")
        limit = float(bound) if "row_rate_error" in q and isinstance(bound, (int, float)) else tol
        off = [r for r in rows if err(r) > limit]
        worst = max(rows, key=err, default=None)
        out = [("LineString", r["polyline_enu"]) for r in (off or ([worst] if worst else []))]
    elif "no_spray" in q:
        out = [("Polygon", [tuple(p) for p in z]) for z in (ctx.world.get("gis") or {}).get("no_spray_enu") or []]
    elif "drift" in q or "fence" in q:
        out = [("Polygon", ctx.fence)] if len(ctx.fence) >= 3 else []
    if not out and q == "status":
        out = [("Point", [tuple(f["position_enu"][:2])]) for f in ctx.summary.get("failsafes") or []
               if isinstance(f, dict) and f.get("position_enu") and None not in f["position_enu"][:2]]
    w = check.get("window")
    if not out and isinstance(w, (list, tuple)) and len(w) == 2:
        out = [("LineString", _path_between(ctx, float(w[0]), float(w[1])))]
    return [LocalFeature(kind, [(float(p[0]), float(p[1])) for p in pts]) for kind, pts in out
            if len(pts) >= (1 if kind == "Point" else 2)]


def failed_checks_layer(ctx: MapContext) -> MapLayer | None:
    """Each failed check where it failed, in red (hover: the check, its value and bound)."""
    from vinecli.report.text import format_value

    feats = []
    for c in ctx.summary.get("checks") or []:
        if c.get("passed"):
            continue
        tip = (f"FAILED check {c.get('name')}: value {format_value(c.get('value'))}, expected {c.get('op')} "
               f"{format_value(c.get('bound'))}")
        for f in locate_check(ctx, c):
            style: dict[str, Any] = {"color": C_FAILED, "weight": 7, "opacity": 0.8, "className": "fm-failed"}
            if f.kind == "Point":
                style |= {"radius": 12, "fillOpacity": 0.2}
            elif f.kind == "Polygon":
                style |= {"weight": 4, "fillColor": C_FAILED, "fillOpacity": 0.12}
            f.properties = {"check": str(c.get("name")), "tip": tip, "style": style}
            feats.append(f)
    if not feats:
        return None
    return MapLayer("failed", "Failed checks", feats, legend=Legend(swatches=[(C_FAILED, "where a check failed",
                                                                                "line")]))
