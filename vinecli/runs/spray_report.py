"""What a grower asks of a spraying run: did every vine get its dose, and if not, where and when not.

* :func:`locate_faults`: each dose fault of ``deposition.json`` (a stretch of a row above the hot band or
  below the gap band) gets the time the vehicle sprayed there (the nearest spraying sample in the time
  series; NaN when nothing was sprayed near it).
* :func:`locate_cutouts`: each ``sprayer_cutout`` event of the autopilot (an open section the sprayer did
  not serve), and the place a phase without refills ran dry with passes left, gets the row and the
  metres along it where it happened, when that lies over a row's planned stretch (cut-outs over the
  run-on past the row ends or the headlands are no dose matter).
* :func:`judge_ending`: a spraying mission whose run says ``completed`` is completed only when every
  planned row stretch of a ``rows_done`` phase was sprayed (90 % of it got half the asked rate or more)
  and the vehicle is down (disarmed on the ground), and a run of any spraying mission only when liquid
  left the nozzles; otherwise ``aborted`` with the cause and the rows left. Positions world ENU m, times s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from vinecli.geometry import segments
from vinecli.specs.mission import MissionSpec, SprayPhase

__all__ = ["ROW_SPRAYED", "describe_spray", "judge_ending", "locate_cutouts", "locate_faults", "row_label"]

#: a planned row stretch counts as sprayed when this share of it got >= 50 % of the asked rate
ROW_SPRAYED = 0.9


def row_label(row: Mapping[str, Any]) -> int:
    """The number a grower knows a row of ``deposition.json`` by: its index among the world's rows when the mission
    targets world rows, else its index among the mission's own rows."""
    w = row.get("world_row")
    return int(w) if w is not None else int(row["row"])


def _spraying_xy(ts: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(times s, positions (N, 2) ENU m) of the samples with liquid leaving the nozzles."""
    flow = np.nan_to_num(np.asarray(ts.get("tank_flow_lps", []), dtype=float))
    on = flow > 0.0
    t = np.asarray(ts["t_s"], dtype=float)[on]
    xy = np.column_stack([np.asarray(ts["pos_enu_x_m"], dtype=float)[on], np.asarray(ts["pos_enu_y_m"], dtype=float)[on]])
    return t, xy


def _point_along(line: Sequence[Sequence[float]], s: float) -> tuple[float, float]:
    """The point ``s`` metres along a polyline (ENU m), clamped to its ends."""
    pts = np.asarray(line, dtype=float)
    seg = np.hypot(*np.diff(pts, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    s = min(max(s, 0.0), float(cum[-1]))
    return float(np.interp(s, cum, pts[:, 0])), float(np.interp(s, cum, pts[:, 1]))


def locate_faults(rows: Sequence[Mapping[str, Any]], ts: Mapping[str, np.ndarray], reach_m: float = 3.0
                  ) -> list[dict[str, Any]]:
    """Every dose fault of the rows of ``deposition.json`` with its row and the time the vehicle sprayed its middle
    (the nearest spraying sample within ``reach_m``; NaN when there is none: nothing was sprayed there)."""
    t, xy = _spraying_xy(ts)
    out = []
    for r in rows:
        for f in r.get("faults") or []:
            x, y = _point_along(r["polyline_enu"], 0.5 * (f["from_m"] + f["to_m"]))
            when = math.nan
            if t.size:
                d = np.hypot(xy[:, 0] - x, xy[:, 1] - y)
                i = int(np.argmin(d))
                when = float(t[i]) if d[i] <= reach_m else math.nan
            out.append({"row": row_label(r), **f, "t_s": when, "position_enu": [x, y]})
    return out


def _row_at(x: float, y: float, rows: Sequence[Mapping[str, Any]], reach_m: float) -> tuple[int, float] | None:
    """(row, metres along it) of the planned row stretch nearest to (x, y) within ``reach_m``, or None."""
    best: tuple[float, int, float] | None = None
    for r in rows:
        planned = r.get("planned_m")
        if not planned:
            continue
        for seg in segments(r["polyline_enu"], len2="hypot"):
            u, d = seg.nearest(x, y)
            s = seg.start + u * seg.length
            if d <= reach_m and planned[0] <= s <= planned[1] and (best is None or d < best[0]):
                best = (d, row_label(r), s)
    return (best[1], best[2]) if best is not None else None


def _position_at(ts: Mapping[str, np.ndarray], t: float) -> list[float]:
    """The vehicle's position (ENU m, x y) at the last sample at or before ``t`` s; NaNs without samples."""
    times = np.asarray(ts.get("t_s", []), dtype=float)
    if not times.size or "pos_enu_x_m" not in ts:
        return [math.nan, math.nan]
    i = max(int(np.searchsorted(times, t, side="right")) - 1, 0)
    return [float(np.asarray(ts["pos_enu_x_m"])[i]), float(np.asarray(ts["pos_enu_y_m"])[i])]


def locate_cutouts(events: Sequence[tuple[float, str, Mapping[str, Any]]], rows: Sequence[Mapping[str, Any]],
                   reach_m: float, ts: Mapping[str, np.ndarray] | None = None) -> list[dict[str, Any]]:
    """The ``sprayer_cutout`` events over a planned row stretch (within ``reach_m`` of the row): time, reason, row,
    metres along it; with the time series ``ts``, also where a phase without refills ran dry with passes left (its
    last ``sortie`` event: the deposit stops there)."""
    out = []
    for t, kind, data in events:
        if kind == "sprayer_cutout":
            p = data.get("position_est_enu") or [math.nan, math.nan]
        elif (kind == "sortie" and ts is not None and data.get("last") and data.get("reason") == "tank empty"
              and data.get("spraying_left_m", 0.0) > 0.0):
            p = _position_at(ts, t)
        else:
            continue
        where = _row_at(float(p[0]), float(p[1]), rows, reach_m)
        if where is not None:
            out.append({"t_s": float(t), "reason": data.get("reason", ""), "row": where[0], "at_m": round(float(where[1]), 2)})
    return out


def judge_ending(status: str, message: str, spec: MissionSpec, rows: Sequence[Mapping[str, Any]] | None,
                 ts: Mapping[str, np.ndarray]) -> tuple[str, str]:
    """(status, message) of a run as a grower would state it (module docstring); unchanged unless a spraying
    mission says ``completed``."""
    phase = next((p for p in spec.phases if isinstance(p, SprayPhase)), None)
    if status != "completed" or phase is None:
        return status, message
    problems = []
    armed = np.asarray(ts.get("armed", [0.0]), dtype=float)
    ground = np.asarray(ts.get("on_ground", [1.0]), dtype=float)
    if armed.size and (armed[-1] > 0.5 or ground[-1] < 0.5):
        problems.append("the vehicle is not down (still armed or in the air at the end)")
    if rows is None:  # no deposition: not a drop left the nozzles
        problems.append("nothing was sprayed (no liquid left the nozzles)")
    elif phase.until == "rows_done":
        left = [(row_label(r), float(r["covered_fraction"])) for r in rows
                if r.get("planned_m") and not float(r.get("covered_fraction") or 0.0) >= ROW_SPRAYED]
        if left:
            listed = ", ".join(f"{i} ({c:.0%})" if c == c else f"{i} (0%)" for i, c in left[:12])
            more = f" and {len(left) - 12} more" if len(left) > 12 else ""
            problems.append(f"{len(left)} planned row stretches not sprayed (rows {listed}{more} covered)")
    if not problems:
        return status, message
    return "aborted", f"not every planned row was sprayed and landed: {'; '.join(problems)} ({message})"


def describe_spray(faults: Sequence[Mapping[str, Any]], cutouts: Sequence[Mapping[str, Any]], most: int = 3) -> str:
    """One phrase for the status message: where the dose left its band and where the sprayer cut out ('' if
    nowhere), e.g. ``dose: hot spot 1.39x on row 8 at 13.0-17.0 m (144.5 s)``."""
    parts = [f"{'hot spot' if f['kind'] == 'hot' else 'gap'} {f['ratio']:.2f}x on row {f['row']} at "
             f"{f['from_m']:.1f}-{f['to_m']:.1f} m" + (f" ({f['t_s']:.1f} s)" if f["t_s"] == f["t_s"] else "")
             for f in faults[:most]]
    parts += [f"sprayer cut-out on row {c['row']} at {c['at_m']:.1f} m ({c['t_s']:.1f} s: {c['reason']})"
              for c in cutouts[:most]]
    more = max(len(faults) - most, 0) + max(len(cutouts) - most, 0)
    return ("dose: " + "; ".join(parts) + (f"; {more} more" if more else "")) if parts else ""
