"""The field map of one run: :data:`LAYERS` (drawing order, bottom first) applied to the run's
:class:`~vinecli.report.fieldmap.context.MapContext`, turned into the browser's data.

Adding a layer is one function ``(ctx: MapContext) -> MapLayer | None`` appended to :data:`LAYERS` (a
prescription map, the as-applied map and their error would each be one, reading their files from
``ctx.run_dir``): the page draws it, lists it in the layer panel with its legend and shows its hover texts
(vectors: each feature's ``tip``; rasters: their values).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.report.fieldmap.as_applied_layers import (
    as_applied_layer,
    canopy_segments_layer,
    dose_error_layer,
    dose_zones_layer,
    prescription_layer,
)
from vinecli.report.fieldmap.context import MapContext, load_context
from vinecli.report.fieldmap.map_model import MapLayer, map_data
from vinecli.report.fieldmap.mark_layers import events_layer, failed_checks_layer
from vinecli.report.fieldmap.raster_layers import canopy_layer, deposition_layer, hillshade_layer
from vinecli.report.fieldmap.vector_layers import (
    fence_layer,
    field_layer,
    no_spray_layer,
    path_phase_layer,
    path_sprayer_layer,
    rows_layer,
)

__all__ = ["LAYERS", "run_map"]

#: the layers, bottom first
LAYERS: list[Callable[[MapContext], MapLayer | None]] = [
    hillshade_layer, canopy_layer, deposition_layer, prescription_layer, as_applied_layer, dose_error_layer,
    dose_zones_layer, canopy_segments_layer, field_layer, no_spray_layer, fence_layer, rows_layer,
    path_sprayer_layer, path_phase_layer, events_layer, failed_checks_layer,
]
MARGIN_M = 4.0


#: the layers a flight that did not spray opens on (the field is a zoom-out away)
FLIGHT_KEYS = ("path_phase", "path_sprayer", "events", "failed")
FLIGHT_VIEW_M = 30.0  # the smallest box a flight's map opens on, m


def _view(ctx: MapContext, layers: list[MapLayer]) -> tuple[float, float, float, float]:
    """The local box the map opens on: a spray run's field (every feature and wet raster cell), a flight's path and
    marks (at least :data:`FLIGHT_VIEW_M` across), with a margin; else the terrain."""
    flight = ctx.deposition is None
    pts = [p for lay in layers if not flight or lay.key in FLIGHT_KEYS for f in lay.features for p in f.coords]
    if flight and pts:
        a = np.asarray(pts, float)
        mid, half = (a.min(axis=0) + a.max(axis=0)) / 2, np.maximum((a.max(axis=0) - a.min(axis=0)) / 2,
                                                                    FLIGHT_VIEW_M / 2 - MARGIN_M)
        pts = [tuple(mid - half), tuple(mid + half)]
    for lay in layers:
        r = lay.raster
        if r is not None and lay.key != "hillshade" and r.values is not None:
            wet = np.argwhere(np.isfinite(r.values) & (r.rgba[..., 3] > 0))
            if wet.size:
                (i0, j0), (i1, j1) = wet.min(axis=0), wet.max(axis=0) + 1
                pts += [(r.x0_m + j0 * r.cell_m, r.y0_m + i0 * r.cell_m), (r.x0_m + j1 * r.cell_m, r.y0_m + i1 * r.cell_m)]
    if not pts and ctx.preview is not None:
        pts = [(float(ctx.preview["x"][0]), float(ctx.preview["y"][0])),
               (float(ctx.preview["x"][-1]), float(ctx.preview["y"][-1]))]
    a = np.asarray(pts or [(0.0, 0.0)], float)
    lo, hi = a.min(axis=0) - MARGIN_M, a.max(axis=0) + MARGIN_M
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


def _crop_terrain(ctx: MapContext, view: tuple[float, float, float, float], margin_m: float = 20.0) -> None:
    """Keep the terrain preview around the view only (a large DSM's hillshade would cost pixels for nothing)."""
    pv = ctx.preview
    if pv is None:
        return
    x0, y0, x1, y1 = view
    kx = (pv["x"] >= x0 - margin_m) & (pv["x"] <= x1 + margin_m)
    ky = (pv["y"] >= y0 - margin_m) & (pv["y"] <= y1 + margin_m)
    if kx.sum() >= 2 and ky.sum() >= 2:
        ctx.preview = {"x": pv["x"][kx], "y": pv["y"][ky], "z": pv["z"][np.ix_(ky, kx)]}


def run_map(run_dir: str | Path, layers: list[Callable[[MapContext], MapLayer | None]] | None = None
            ) -> dict[str, Any]:
    """The browser's data of the field map of one run (:func:`~vinecli.report.fieldmap.map_model.map_data`), with
    ``located``: the failed checks the map shows a place for."""
    ctx = load_context(run_dir)
    fns = LAYERS if layers is None else layers
    vector = [lay for fn in fns if fn is not hillshade_layer and (lay := fn(ctx)) is not None]
    view = _view(ctx, vector)
    _crop_terrain(ctx, view)
    shade = hillshade_layer(ctx) if hillshade_layer in fns else None
    made = [*([shade] if shade is not None else []), *vector]
    s = ctx.summary
    title = f"{s.get('case') or s.get('run_id')} — {s.get('mission', '')}, world {(s.get('world') or {}).get('name', '-')}"
    data = map_data(made, ctx.georef, view_local=view, title=title, note=ctx.georef_note)
    data["aspect"] = (view[3] - view[1]) / max(view[2] - view[0], 1e-9)
    data["located"] = sorted({str(f.properties["check"]) for lay in made if lay.key == "failed" for f in lay.features})
    return data
