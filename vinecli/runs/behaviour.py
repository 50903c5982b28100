"""Behaviour figures of a finished run, to compare autopilots flying the same mission.

From a run directory (``timeseries.parquet``, ``events.jsonl``, ``summary.json``):

* ``takeoff_time_s``: lift-off to the first sample at 95 % of the first takeoff phase's
  altitude above the start (a rise time: independent of where each autopilot accepts the item);
* ``hover_error_max_m`` / ``hover_error_rms_m``: horizontal distance from the mean hold position
  over the first hold phase (from 8 s into it, as the gust mission's checks);
* ``spray_path_p95_m``: 95th percentile of the distance to the nearest row while the flow is on (the row's
  line run on 5 m past its ends: the passes spray on past them for the spray footprint);
* ``landing_time_s``: start of the last phase (land) to the last touchdown.

A figure that does not apply to the run is None.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.geometry import point_polyline_distance
from vinecli.runs import rundir


def _first_event(events: list[dict[str, Any]], kind: str) -> float | None:
    times = [float(e["t_s"]) for e in events if e["kind"] == kind]
    return min(times) if times else None


def _phase_span(t: np.ndarray, phase: np.ndarray, index: int) -> tuple[float, float] | None:
    sel = np.nonzero(phase == index)[0]
    return (float(t[sel[0]]), float(t[sel[-1]])) if sel.size else None


def behaviour_figures(run_dir: str | Path, *, hold_settle_s: float = 8.0) -> dict[str, float | None]:
    """The figures of the module docstring for one run directory."""
    run_dir = Path(run_dir)
    ts = rundir.read_timeseries(run_dir / rundir.TIMESERIES)
    events = rundir.read_events(run_dir / rundir.EVENTS)
    summary = rundir.read_summary(run_dir)
    from vinecli.missions.spec_io import load_mission

    mission = load_mission(run_dir / rundir.MISSION, check_vehicle=False)
    t, phase = ts["t_s"], ts["phase_index"]
    x, y, z = ts["pos_enu_x_m"], ts["pos_enu_y_m"], ts["pos_enu_z_m"]
    out: dict[str, float | None] = {"takeoff_time_s": None, "hover_error_max_m": None, "hover_error_rms_m": None,
                                    "spray_path_p95_m": None, "landing_time_s": None}
    types = [p.type for p in mission.phases]
    liftoff = _first_event(events, "liftoff")
    if types and types[0] == "takeoff" and liftoff is not None:
        first = mission.phases[0]
        level = z[0] + 0.95 * first.altitude_agl_m  # type: ignore[union-attr]
        reached = np.nonzero((t >= liftoff) & (z >= level))[0]
        out["takeoff_time_s"] = float(t[reached[0]] - liftoff) if reached.size else None
    if "hold" in types:
        span = _phase_span(t, phase, types.index("hold"))
        if span is not None:
            sel = (t >= span[0] + hold_settle_s) & (t <= span[1])
            if sel.sum() > 1:
                ex, ey = x[sel] - x[sel].mean(), y[sel] - y[sel].mean()
                d = np.hypot(ex, ey)
                out["hover_error_max_m"] = float(d.max())
                out["hover_error_rms_m"] = float(math.sqrt(float(np.mean(d * d))))
    rows = (summary.get("world") or {}).get("rows_enu") or []
    flow = ts.get("tank_flow_cmd_lps")
    if "spray" in types and flow is not None and rows:
        spec = mission.phases[types.index("spray")]
        if isinstance(spec.rows, list) and spec.rows and isinstance(spec.rows[0], int):  # type: ignore[union-attr]
            rows = [rows[i] for i in spec.rows]  # type: ignore[union-attr,index]
        on = flow > 0
        if on.any():
            lines = [_run_on(r, 5.0) for r in rows]
            out["spray_path_p95_m"] = float(np.percentile(point_polyline_distance(x[on], y[on], lines), 95))
    if types and types[-1] == "land":
        span = _phase_span(t, phase, len(types) - 1)
        downs = [float(e["t_s"]) for e in events if e["kind"] == "touchdown"]
        if span is not None and downs and downs[-1] >= span[0]:
            out["landing_time_s"] = downs[-1] - span[0]
    return out


__all__ = ["behaviour_figures"]


def _run_on(row: list[list[float]], m: float) -> list[tuple[float, float]]:
    """A row polyline (ENU m) run on straight past both ends by ``m`` metres."""
    p = np.asarray(row, dtype=float)
    d0, d1 = p[0] - p[1], p[-1] - p[-2]
    d0, d1 = d0 / (np.linalg.norm(d0) or 1.0), d1 / (np.linalg.norm(d1) or 1.0)
    return [tuple(p[0] + m * d0), *map(tuple, p), tuple(p[-1] + m * d1)]
