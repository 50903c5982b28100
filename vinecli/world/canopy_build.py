"""World build: the ``canopy:`` spec resolved into every row's hedge (world.json ``canopy``), docs/budget.md.

Precedence per field: a row's own override > the world's value > the growth stage's default
(:data:`vinecli.spray.canopy.BBCH_DEFAULTS`). ``source: chm`` replaces each row's top by the height
the world's surface model shows (:func:`vinecli.spray.canopy.measure_row_heights`), the foliage
base keeping the stage's base-to-top ratio, unless given.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence

import numpy as np

from vinecli.errors import SpecError
from vinecli.rows.canopy_segments import CanopySegments, Sampling, hedge_segments, segment_canopy
from vinecli.specs.canopy import CanopySpec
from vinecli.spray.canopy import Canopy, Hedge, bbch_dims, measure_row_heights, row_spacing

__all__ = ["canopy_segments", "resolve_canopy"]

log = logging.getLogger(__name__)


def resolve_canopy(spec: CanopySpec, rows: Sequence[Sequence[Sequence[float]]],
                   height: Callable[[np.ndarray, np.ndarray], np.ndarray] | None, width_m: float | None = None,
                   where: str = "") -> Canopy:
    """Every row's hedge of ``spec`` on ``rows`` (ENU polylines); ``height``: the surface model for ``source: chm``.

    ``width_m``: the world's canopy width when the world file set it (used when ``spec.width_m`` is unset).
    """
    lines = [[(float(p[0]), float(p[1])) for p in r] for r in rows]
    stage = bbch_dims(spec.bbch)
    spacing = row_spacing(lines)
    base = spec.base_m if spec.base_m is not None else stage.base_m
    top = spec.top_m if spec.top_m is not None else stage.top_m
    width = spec.width_m if spec.width_m is not None else (width_m if width_m is not None else stage.width_m)
    lad = spec.lad_m2m3 if spec.lad_m2m3 is not None else stage.lad_m2m3
    tops = [top] * len(lines)
    notes = []
    if spec.source == "chm":
        if height is None:
            raise SpecError("canopy source 'chm' needs a terrain built from a surface model (DSM)", path=where or None)
        if not math.isfinite(spacing):
            raise SpecError("canopy source 'chm' needs at least two rows (the ground is read between them)",
                            path=where or None)
        tops = measure_row_heights(height, lines, max(width, 0.1), spacing)
        ratio = stage.base_m / stage.top_m if stage.top_m > 0 else 0.0
        notes.append(f"row heights measured on the surface model: median {float(np.median(tops)):.2f} m")
        if spec.base_m is None:
            base = math.nan  # per row, below
        log.info("canopy: %s", notes[-1])
    over = {o.row: o for o in spec.rows}
    for i in over:
        if i >= len(lines):
            raise SpecError(f"canopy.rows: row {i} does not exist ({len(lines)} rows)", path=where or None)
    hedges = []
    for i, t in enumerate(tops):
        o = over.get(i)
        b = base if math.isfinite(base) else t * ratio
        h = Hedge(row=i,
                  base_m=o.base_m if o is not None and o.base_m is not None else b,
                  top_m=o.top_m if o is not None and o.top_m is not None else t,
                  width_m=o.width_m if o is not None and o.width_m is not None else width,
                  lad_m2m3=o.lad_m2m3 if o is not None and o.lad_m2m3 is not None else lad)
        if h.top_m < h.base_m:
            h = Hedge(i, h.top_m, h.top_m, h.width_m, h.lad_m2m3)
        hedges.append(h)
    return Canopy(rows=tuple(tuple(r) for r in lines), hedges=tuple(hedges), profile=tuple(spec.profile),
                  g_factor=spec.g_factor, leaf_width_m=spec.leaf_width_m, source=spec.source, bbch=spec.bbch,
                  spacing_m=spacing, notes=tuple(notes))


def canopy_segments(spec: CanopySpec, canopy: Canopy,
                    height: Callable[[np.ndarray, np.ndarray], np.ndarray] | None) -> CanopySegments | None:
    """The rows' canopy segment by segment (docs/dose.md): measured on the surface model for ``source: chm``
    (each row's foliage base its hedge's), else the given hedges cut into uniform segments; None without rows
    or without a row spacing (one row)."""
    if not canopy.hedges or not math.isfinite(canopy.spacing_m):
        return None
    if spec.source == "chm" and height is not None:
        step = 0.1
        return segment_canopy(height, canopy.rows, spacing_m=canopy.spacing_m,
                              base_m=[h.base_m for h in canopy.hedges], segment_m=spec.segment_m,
                              sampling=Sampling(step_m=step, gap_min_m=spec.gap_min_m))
    return hedge_segments(canopy.rows, canopy.hedges, canopy.spacing_m, spec.segment_m)
