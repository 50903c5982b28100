"""As applied: what a run with segment rates (a canopy dose or a prescription map) delivered, against the
prescription, as field controllers log it (docs/dose.md §6). World ENU m, L/ha of ground, litres.

Each row of the dosed phase is cut into ``bin_m`` (0.1 m) bins within its planned stretch. Two applied rates:

* **pump** (``pump_lpha``): what the pump delivered, ``flow / (ground speed x track width) x 10 000``, the rate
  an as-applied log of a field controller records (flow meter and speed; Colaço et al. 2014, Luck et al. 2010):
  every recorded sample of the spray phase with the vehicle (its CoM) within half a track width of a row and at
  a quarter of the phase's speed or more is projected onto the row; each pass over the row (a run of such samples
  with some flow: a transit with the sections closed is none) is interpolated onto the bins it crossed, passes
  add up;
* **deposit** (``deposit_lpha``): what reached the canopy band (row ± canopy width / 2) on the deposition map
  (:func:`~vinecli.missions.deposition_metrics.row_profiles`): the pump's rate spread by the spray's footprint,
  the wind and the downwash.

Judged on the pump rate (:mod:`vinecli.missions.dose_steps` for the steps and gaps): the share of the sprayed row
length within ``tolerance`` (±10 %) of the prescription, the mean error per zone (the map's zones; for a dose
expression, classes of the prescribed rate), the transition distance at each rate step against its bound, no
spray over gaps, and the product used against a uniform rate over the same rows.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vinecli.geometry import distance_along, polyline_length
from vinecli.missions.dose_steps import POSITION_MARGIN_M, PassRates, StepRecord, gap_records, step_records, traversals
from vinecli.rows.detect import Polyline
from vinecli.rows.dose_units import HA_M2
from vinecli.rows.segment_rates import SegmentRates

__all__ = ["AS_APPLIED_METRICS", "AsApplied", "DoseRun", "as_applied", "rate_zones"]

#: name -> (unit, description); registered in vinecli.missions.metrics.METRICS
AS_APPLIED_METRICS: dict[str, tuple[str, str]] = {
    "dose_in_band_fraction": ("1", "Share of the sprayed row length whose pump-delivered rate lies within ±10 % of its "
                                   "segment's prescribed rate"),
    "dose_in_band_fraction_deposit": ("1", "The same on the deposit reaching the canopy band (deposition map)"),
    "dose_zone_error_max": ("1", "Largest |mean pump-rate error| of a zone (a map's zone or a rate class)"),
    "dose_transitions": ("1", "Rate steps along the rows judged (transition distance against its bound)"),
    "dose_transitions_over_bound": ("1", "Rate steps whose transition distance exceeded its bound (pump lag x speed)"),
    "dose_transition_max_m": ("m", "Longest transition distance of a rate step, m (until within ±10 %)"),
    "dose_gaps_sprayed": ("1", "Gaps (no canopy, rate 0) sprayed beyond the pump's run-down at their ends"),
    "dose_gap_litres": ("L", "Litres the pump delivered over gaps, L (their ends' run-down included)"),
    "dose_applied_l": ("L", "Litres the pump delivered over the rows' planned stretches, L"),
    "dose_prescribed_l": ("L", "Litres the prescription asks for over the same stretches, L"),
    "dose_uniform_l": ("L", "Litres a uniform rate (the phase's uniform reference) would apply there, L"),
    "dose_saving_l": ("L", "Uniform-rate litres minus the litres delivered over the rows, L"),
    "dose_saving_pct": ("%", "The saving against the uniform rate, % of the uniform litres"),
    "dose_out_of_range_m": ("m", "Path length the sprayer could not fly at its prescribed rate and speed (slowed, "
                                 "over- or under-dosed), m"),
}

_SPEED_FRACTION = 0.25  # samples below this share of the phase's speed are not mapped (hover, turn-arounds)


@dataclass(frozen=True)
class DoseRun:
    """What the as-applied judgement needs of a run's dosed spray phase: its index, its rows (the rates' ``row``
    indices refer to them), the plan's track width (m) and stretches, the phase's speed (m/s), the pump's time
    constants (s), the canopy width (m), the recording rate (Hz), the position margin (m) and speed noise (m/s)
    of the step bounds (:mod:`vinecli.missions.dose_steps`)."""

    phase_index: int
    rows: Sequence[Polyline]
    flow_width_m: float
    stretches: Mapping[int, tuple[float, float]]
    speed_mps: float
    tau_up_s: float
    tau_down_s: float
    canopy_width_m: float = 0.6
    record_rate_hz: float = 50.0
    position_margin_m: float = POSITION_MARGIN_M  # along-track error of the autopilot's position estimate, m
    speed_noise_mps: float = 0.0  # error of the autopilot's ground speed (its flow follows it), m/s


@dataclass
class AsApplied:
    """The as-applied figures of a run (module docstring); ``bins``: per row (s_m, prescribed, pump, deposit,
    segment index) arrays; ``segments``: one dict per rate segment; ``per_second``: the 1 Hz log."""

    bins: list[dict[str, np.ndarray]]
    segments: list[dict[str, Any]]
    per_second: list[dict[str, Any]]
    zones: list[dict[str, Any]]
    steps: list[StepRecord]
    gaps: list[dict[str, Any]]
    product: dict[str, float]
    metrics: dict[str, float] = field(default_factory=dict)
    tolerance: float = 0.1

    def doc(self) -> dict[str, Any]:
        """The JSON document of ``as_applied.json`` (without the bins)."""
        return {"tolerance": self.tolerance, "metrics": self.metrics, "product": self.product, "zones": self.zones,
                "transitions": [s.to_dict() for s in self.steps], "gaps": self.gaps, "segments": self.segments}


def rate_zones(rates: Sequence[float] | np.ndarray, classes: int = 5, distinct_max: int = 12) -> tuple[np.ndarray, list[str]]:
    """Zone index of each prescribed rate (L/ha, > 0) and the zones' names: the distinct rates (a map's zones)
    when there are at most ``distinct_max``, else ``classes`` equal classes between the lowest and highest."""
    r = np.asarray(rates, dtype=float)
    distinct = np.unique(np.round(r, 3))
    if distinct.size <= distinct_max:
        return np.searchsorted(distinct, np.round(r, 3)), [f"{v:g} L/ha" for v in distinct]
    lo, hi = float(r.min()), float(r.max())
    edges = np.linspace(lo, hi, classes + 1)
    k = np.clip(np.searchsorted(edges, r, side="right") - 1, 0, classes - 1)
    return k, [f"{a:.1f}-{b:.1f} L/ha" for a, b in zip(edges[:-1], edges[1:], strict=True)]


def _row_bins(rates: SegmentRates, run: DoseRun, bin_m: float) -> list[dict[str, np.ndarray]]:
    """Per row: bin centres (m), prescribed rate and segment index of each bin within the planned stretch."""
    out = []
    index = {id(g): i for i, g in enumerate(rates.segments)}
    for k, line in enumerate(run.rows):
        length = polyline_length(line)
        a, b = run.stretches.get(k, (0.0, length))
        s = (np.arange(int(math.ceil(length / bin_m))) + 0.5) * bin_m
        s = s[(s >= a) & (s <= b)]
        segs = sorted((g for g in rates.segments if g.row == k), key=lambda g: g.s0_m)
        seg = np.full(s.size, -1)
        presc = np.zeros(s.size)
        if segs:
            s0 = np.array([g.s0_m for g in segs])
            j = np.clip(np.searchsorted(s0, s, side="right") - 1, 0, len(segs) - 1)
            seg = np.array([index[id(segs[i])] for i in j]) if s.size else seg
            presc = np.array([segs[i].rate_lpha for i in j]) if s.size else presc
        out.append({"s_m": s, "prescribed": presc, "segment": seg, "pump": np.zeros(s.size),
                    "deposit": np.full(s.size, np.nan)})
    return out


def _samples(ts: Mapping[str, np.ndarray], run: DoseRun) -> dict[str, np.ndarray]:
    """The spray phase's samples: time, position, ground speed, delivered flow, pump rate (L/ha), the nearest row
    within half a track width and s along it (the 1 Hz log), and for every row the s of the samples within half a
    track width of it (NaN elsewhere: a broadcast pass's track covers several rows, each gets its rate)."""
    phase = np.asarray(ts["phase_index"]) == run.phase_index
    x, y = np.asarray(ts["pos_enu_x_m"])[phase], np.asarray(ts["pos_enu_y_m"])[phase]
    v = np.hypot(np.asarray(ts["vel_enu_x_mps"])[phase], np.asarray(ts["vel_enu_y_mps"])[phase])
    q = np.nan_to_num(np.asarray(ts["tank_flow_lps"], dtype=float)[phase])
    moving = v >= _SPEED_FRACTION * run.speed_mps
    pump = np.where(moving, q / np.maximum(v, 1e-9) / run.flow_width_m * HA_M2, np.nan)
    row = np.full(x.size, -1)
    s = np.full(x.size, np.nan)
    best = np.full(x.size, np.inf)
    per_row = []
    for k, line in enumerate(run.rows):
        d, sk = distance_along(x, y, line)
        within = (d <= 0.5 * run.flow_width_m) & (sk > 0.0) & (sk < polyline_length(line))
        per_row.append(np.where(within, sk, np.nan))
        inside = within & (d < best)
        row = np.where(inside, k, row)
        s = np.where(inside, sk, s)
        best = np.where(inside, d, best)
    return {"t": np.asarray(ts["t_s"])[phase], "x": x, "y": y, "v": v, "q": q, "pump": pump, "row": row, "s": s,
            "moving": moving, "s_rows": np.array(per_row).reshape(len(per_row), x.size)}


def _fill_pump(bins: list[dict[str, np.ndarray]], smp: dict[str, np.ndarray]) -> list[list[PassRates]]:
    """Add each pass's pump rate onto the bins it crossed; per row its passes."""
    passes: list[list[PassRates]] = [[] for _ in bins]
    over = np.isfinite(smp["s_rows"]) & smp["moving"]
    for k, idx in ((row, idx) for row in range(len(bins)) for idx in traversals(over[row])):
        if not (smp["q"][idx] > 0.0).any():  # flown over with the sections closed (a transit): no pass
            continue
        s, r = smp["s_rows"][k][idx], smp["pump"][idx]
        direction = 1 if s[-1] >= s[0] else -1
        order = np.argsort(s)
        s, r = s[order], r[order]
        b = bins[k]["s_m"]
        hit = np.flatnonzero((b >= s[0]) & (b <= s[-1]))
        if hit.size == 0:
            continue
        vals = np.interp(b[hit], s, r)
        bins[k]["pump"][hit] += vals
        passes[k].append(PassRates(hit, vals, direction, float(np.mean(smp["v"][idx]))))
    return passes


def _fill_deposit(bins: list[dict[str, np.ndarray]], run: DoseRun, grid: Any, volume_l: np.ndarray,
                  bin_m: float) -> None:
    from vinecli.missions.deposition_metrics import row_profiles

    for b, prof in zip(bins, row_profiles(grid, volume_l, list(run.rows), 0.5 * run.canopy_width_m, bin_m),
                       strict=True):
        idx = np.clip(np.round(b["s_m"] / bin_m - 0.5).astype(np.int64), 0, prof["rate_lpha"].size - 1)
        b["deposit"] = np.nan_to_num(prof["rate_lpha"][idx], nan=0.0)


def _in_band(bins: list[dict[str, np.ndarray]], key: str, tol: float) -> float:
    num = den = 0.0
    for b in bins:
        p = b["prescribed"]
        sprayed = p > 0.0
        den += float(sprayed.sum())
        num += float((sprayed & (np.abs(b[key] - p) <= tol * p)).sum())
    return num / den if den > 0 else math.nan


def _segments(rates: SegmentRates, bins: list[dict[str, np.ndarray]], tol: float) -> list[dict[str, Any]]:
    """One record per rate segment within a planned stretch: prescribed, pump and deposit means, errors."""
    out = []
    for k, b in enumerate(bins):
        for j in np.unique(b["segment"][b["segment"] >= 0]):
            g = rates.segments[int(j)]
            sel = b["segment"] == j
            pump, dep = float(b["pump"][sel].mean()), float(b["deposit"][sel].mean())
            r = g.rate_lpha
            mid = (0.5 * (g.start_enu[0] + g.end_enu[0]), 0.5 * (g.start_enu[1] + g.end_enu[1]))
            out.append({"segment": int(j), "row": k, "s0_m": g.s0_m, "s1_m": g.s1_m, "gap": g.gap, "mid_enu": mid,
                        "wall_height_m": g.wall_height_m, "width_m": g.width_m, "lwa_m2pha": g.lwa_m2pha,
                        "start_enu": g.start_enu, "end_enu": g.end_enu, "prescribed_lpha": r, "pump_lpha": pump,
                        "deposit_lpha": dep if math.isfinite(dep) else None,
                        "pump_error": pump / r - 1.0 if r > 0 else None,
                        "deposit_error": dep / r - 1.0 if r > 0 and math.isfinite(dep) else None,
                        "pump_in_band": bool(abs(pump - r) <= tol * r) if r > 0 else pump <= 0.0})
    return out


def _zones(bins: list[dict[str, np.ndarray]], spacing: float, bin_m: float) -> list[dict[str, Any]]:
    pres = np.concatenate([b["prescribed"] for b in bins]) if bins else np.zeros(0)
    pump = np.concatenate([b["pump"] for b in bins]) if bins else np.zeros(0)
    dep = np.concatenate([b["deposit"] for b in bins]) if bins else np.zeros(0)
    sprayed = pres > 0
    if not sprayed.any():
        return []
    zone, names = rate_zones(pres[sprayed])
    out = []
    for z, name in enumerate(names):
        sel = zone == z
        p, a, d = pres[sprayed][sel], pump[sprayed][sel], dep[sprayed][sel]
        if not p.size:
            continue
        out.append({"zone": name, "length_m": round(p.size * bin_m, 2), "prescribed_l": p.sum() * bin_m * spacing / HA_M2,
                    "pump_error": float(a.sum() / p.sum() - 1.0),
                    "deposit_error": float(np.nansum(d) / p.sum() - 1.0) if np.isfinite(d).any() else None,
                    "pump_in_band": float((np.abs(a - p) <= 0.1 * p).mean())})
    return out


def _per_second(smp: dict[str, np.ndarray], rates: SegmentRates) -> list[dict[str, Any]]:
    """The 1 Hz log: the first sample of every second from the phase's start."""
    t = smp["t"]
    if not t.size:
        return []
    sec = np.floor(t - t[0] + 1e-9)
    first = np.flatnonzero(np.concatenate([[True], sec[1:] != sec[:-1]]))
    out = []
    for i in first:
        k = int(smp["row"][i])
        presc = rates.rate_at(k, float(smp["s"][i])) if k >= 0 else 0.0
        pump = float(smp["pump"][i]) if k >= 0 and math.isfinite(smp["pump"][i]) else (0.0 if smp["q"][i] <= 0 else None)
        out.append({"t_s": float(t[i]), "x": float(smp["x"][i]), "y": float(smp["y"][i]), "row": k,
                    "s_m": float(smp["s"][i]) if k >= 0 else None, "prescribed_lpha": presc, "pump_lpha": pump,
                    "flow_lps": float(smp["q"][i]), "speed_mps": float(smp["v"][i])})
    return out


def as_applied(ts: Mapping[str, np.ndarray], rates: SegmentRates, run: DoseRun, *, grid: Any = None,
               volume_l: np.ndarray | None = None, tolerance: float = 0.1, bin_m: float = 0.1,
               out_of_range_m: float = 0.0) -> AsApplied:
    """The as-applied figures of one run (module docstring); ``grid``/``volume_l``: its deposition map (None: no
    deposit column); ``out_of_range_m``: path length the plan flew outside the sprayer's range (dose_plan event)."""
    bins = _row_bins(rates, run, bin_m)
    smp = _samples(ts, run)
    passes = _fill_pump(bins, smp)
    if grid is not None and volume_l is not None:
        _fill_deposit(bins, run, grid, volume_l, bin_m)
    steps = step_records(rates, bins, passes, run, tolerance, bin_m)
    gaps = gap_records(rates, bins, passes, run, tolerance, bin_m)
    spacing = rates.spacing_m
    per_l = bin_m * spacing / HA_M2
    applied = sum(float(b["pump"].sum()) for b in bins) * per_l
    prescribed = sum(float(b["prescribed"].sum()) for b in bins) * per_l
    uniform = rates.uniform_rate_lpha * sum(b["s_m"].size for b in bins) * per_l
    product = {"applied_l": applied, "prescribed_l": prescribed, "uniform_l": uniform,
               "uniform_rate_lpha": rates.uniform_rate_lpha, "saving_l": uniform - applied,
               "saving_pct": 100.0 * (uniform - applied) / uniform if uniform > 0 else math.nan,
               "plan_saving_pct": float(rates.summary()["saving_pct"])}
    zones = _zones(bins, spacing, bin_m)
    judged = [s for s in steps if s.judged]
    metrics = {
        "dose_in_band_fraction": _in_band(bins, "pump", tolerance),
        "dose_in_band_fraction_deposit": _in_band(bins, "deposit", tolerance) if grid is not None else math.nan,
        "dose_zone_error_max": max((abs(z["pump_error"]) for z in zones), default=math.nan),
        "dose_transitions": float(len(judged)),
        "dose_transitions_over_bound": float(sum(1 for s in judged if not s.within_bound)),
        "dose_transition_max_m": max((s.distance_m for s in steps), default=0.0),
        "dose_gaps_sprayed": float(sum(1 for g in gaps if g["sprayed"])),
        "dose_gap_litres": float(sum(g["litres"] for g in gaps)),
        "dose_applied_l": applied, "dose_prescribed_l": prescribed, "dose_uniform_l": uniform,
        "dose_saving_l": product["saving_l"], "dose_saving_pct": product["saving_pct"],
        "dose_out_of_range_m": out_of_range_m,
    }
    return AsApplied(bins, _segments(rates, bins, tolerance), _per_second(smp, rates), zones, steps, gaps, product,
                     metrics, tolerance)
