"""Whole-field spray jobs from a run's time series: sorties, rows sprayed, area rate.

Plain numpy on the recorded columns (docs/architecture.md): ``sortie`` (1, 2, ... from the
built-in autopilot), ``tank_flow_lps`` (delivered flow), ``power_elec_w`` (battery power drawn),
positions ENU in metres. Rows are ENU polylines.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

Polyline = Sequence[tuple[float, float]]

#: a row point counts as sprayed when the vehicle delivered liquid within this horizontal distance, m
SPRAYED_RADIUS_M = 0.5
#: spacing of the sample points along each row, m
ROW_SAMPLE_M = 0.25


def integral(ts: Mapping[str, np.ndarray], col: str, sel: np.ndarray | None = None) -> float:
    """∫ col dt over the rows in ``sel`` (each row holds its value until the next row)."""
    t = np.asarray(ts["t_s"], dtype=float)
    y = np.nan_to_num(np.asarray(ts[col], dtype=float))
    if t.size < 2:
        return 0.0
    dt = np.append(np.diff(t), 0.0)
    w = y * dt
    return float(np.sum(w[sel] if sel is not None else w))


def sorties(ts: Mapping[str, np.ndarray], events: Sequence[tuple[float, str, dict]] = ()) -> list[dict[str, object]]:
    """One entry per sortie: number, start/end time (s), volume sprayed (L), energy drawn (Wh),
    why it ended and the breakpoint (ENU m) from the autopilot's ``sortie`` events."""
    if "sortie" not in ts or np.all(np.isnan(np.asarray(ts["sortie"], dtype=float))):
        return []
    t = np.asarray(ts["t_s"], dtype=float)
    s = np.asarray(ts["sortie"], dtype=float)
    ends = {int(d.get("sortie", 0)): d for _t, kind, d in events if kind == "sortie" and d.get("event") == "end"}
    out: list[dict[str, object]] = []
    for n in np.unique(s[~np.isnan(s)]).astype(int):
        sel = s == n
        idx = np.flatnonzero(sel)
        end = ends.get(int(n), {})
        entry: dict[str, object] = {
            "sortie": int(n),
            "t_start_s": float(t[idx[0]]),
            "t_end_s": float(t[idx[-1]]),
            "volume_l": integral(ts, "tank_flow_lps", sel) if "tank_flow_lps" in ts else 0.0,
            "energy_wh": integral(ts, "power_elec_w", sel) / 3600.0 if "power_elec_w" in ts else math.nan,
            "end_reason": end.get("reason", "job done"),
            "breakpoint_enu": end.get("breakpoint_enu"),
        }
        out.append(entry)
    return out


def _row_samples(rows: Sequence[Polyline]) -> list[np.ndarray]:
    out = []
    for r in rows:
        p = np.asarray(r, dtype=float)
        if len(p) < 2:
            continue
        seg = np.hypot(*np.diff(p, axis=0).T)
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        s = np.linspace(0.0, cum[-1], max(2, int(math.ceil(cum[-1] / ROW_SAMPLE_M)) + 1))
        out.append(np.column_stack([np.interp(s, cum, p[:, 0]), np.interp(s, cum, p[:, 1])]))
    return out


def rows_sprayed(ts: Mapping[str, np.ndarray], rows: Sequence[Polyline]) -> tuple[float, float]:
    """(fraction of the rows' length sprayed, sprayed row length in m): a row point is sprayed when
    liquid was delivered within ``SPRAYED_RADIUS_M`` of it."""
    samples = _row_samples(rows)
    if not samples:
        return math.nan, 0.0
    flow = np.nan_to_num(np.asarray(ts["tank_flow_lps"], dtype=float))
    on = flow > 0.0
    total = sum(float(np.hypot(*np.diff(np.asarray(r, dtype=float), axis=0).T).sum()) for r in rows if len(r) >= 2)
    if not on.any() or total <= 0.0:
        return 0.0, 0.0
    xy = np.column_stack([np.asarray(ts["pos_enu_x_m"], dtype=float)[on], np.asarray(ts["pos_enu_y_m"], dtype=float)[on]])
    from scipy.spatial import cKDTree  # ~0.2 s to import: only where row coverage is measured

    tree = cKDTree(xy)
    pts = np.vstack(samples)
    d, _ = tree.query(pts, distance_upper_bound=SPRAYED_RADIUS_M)
    frac = float(np.mean(np.isfinite(d)))
    return frac, frac * total




def operations(ts: Mapping[str, np.ndarray], events: Sequence[tuple[float, str, dict]], area_ha: float
               ) -> dict[str, float]:
    """The operations figures of a job (SI, ha): from the first lift-off to the last touchdown (else the end),
    the time airborne, spraying and on the ground between sorties (idle: refills, battery swaps, handling), the
    sorties, refills and battery swaps, the litres and the energy, and per treated hectare (``area_ha``: the
    rows' planned stretches x their spacing) the field capacity (ha/h), litres and energy."""
    t = np.asarray(ts["t_s"], dtype=float)
    nan = math.nan
    lift = [tt for tt, kind, _d in events if kind == "liftoff"]
    down = [tt for tt, kind, _d in events if kind == "touchdown"]
    if not lift or t.size < 2:
        return {}
    t0 = float(min(lift))
    t1 = float(max(down)) if down and max(down) > t0 else float(t[-1])
    span = (t >= t0) & (t <= t1)
    dt = np.append(np.diff(t), 0.0)
    air = ~(np.asarray(ts.get("on_ground", np.zeros(t.size)), dtype=float) > 0.5)
    flow = np.nan_to_num(np.asarray(ts.get("tank_flow_lps", np.zeros(t.size)), dtype=float))
    job_s = t1 - t0
    air_s = float(dt[span & air].sum())
    litres = integral(ts, "tank_flow_lps") if "tank_flow_lps" in ts else 0.0
    energy = integral(ts, "power_elec_w") / 3600.0 if "power_elec_w" in ts else nan
    n_sorties = float(np.nanmax(ts["sortie"])) if "sortie" in ts and np.isfinite(ts["sortie"]).any() else 1.0
    ok = area_ha > 0 and math.isfinite(area_ha)
    return {
        "job_time_s": job_s, "airborne_s": air_s, "spraying_s": float(dt[span & (flow > 0)].sum()),
        "idle_s": job_s - air_s, "idle_fraction": (job_s - air_s) / job_s if job_s > 0 else nan,
        "sorties": n_sorties, "refills": float(sum(1 for _t, k, _d in events if k == "refill")),
        "battery_swaps": float(sum(1 for _t, k, _d in events if k == "battery_swap")),
        "litres": litres, "energy_wh": energy, "treated_area_ha": area_ha if ok else nan,
        "field_capacity_ha_per_h": area_ha / (job_s / 3600.0) if ok and job_s > 0 else nan,
        "litres_per_ha": litres / area_ha if ok else nan, "energy_wh_per_ha": energy / area_ha if ok else nan,
    }
