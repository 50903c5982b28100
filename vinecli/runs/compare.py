"""Autopilots side by side: the same mission, world and seed flown by the built-in autopilot, PX4 and
ArduPilot, compared on what a spraying operator looks at.

Per run directory (:func:`autopilot_figures`): status, the firmware that flew; tracking error (cross-track
RMS while spraying, else the horizontal hold error), mission time (lift-off to the last touchdown, and the
whole run), energy drawn from the pack; from the deposition (``deposition.json``), the dose on each
targeted row (mean rate, L/ha, and its ratio to the asked rate) and the share of the rows' planned length in a
hot spot or a gap as the run's default dose checks judge them (``dose_hot_spots`` / ``dose_gaps``: 1 m windows
above the mission's ``dose.hot_ratio`` or below its ``gap_ratio`` x the asked rate, :mod:`vinecli.missions.dose`);
a deposition without those bands (older runs) falls back to 0.5 m segments above :data:`HOT_FACTOR` or below
:data:`GAP_FACTOR` x. :func:`compare_runs` groups runs of one mission and seed by autopilot.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import VinecliError
from vinecli.inputs import read_input_json
from vinecli.runs import rundir
from vinecli.runs.behaviour import behaviour_figures
from vinecli.runs.rundir import finite_or_none

HOT_FACTOR = 2.0  # a stretch of row dosed at more than twice the asked rate
GAP_FACTOR = 0.5  # ... or at less than half of it (row_coverage_fraction's threshold)
#: the compared figures: key -> (label, unit)
FIGURES: dict[str, tuple[str, str]] = {
    "tracking_error_m": ("tracking error", "m"),
    "mission_time_s": ("lift-off to touchdown", "s"),
    "sim_time_s": ("run time", "s"),
    "energy_wh": ("energy", "Wh"),
    "mean_rate_lpha_on_rows": ("mean dose on rows", "L/ha"),
    "row_coverage_fraction": ("rows covered", "1"),
    "hot_spot_fraction": ("row length in hot spots", "1"),
    "gap_fraction": ("row length in gaps", "1"),
}


def dose_figures(run_dir: Path) -> dict[str, Any]:
    """Dose per targeted row and the hot-spot / gap shares of their length (None without deposition)."""
    path = run_dir / "deposition.json"
    if not path.is_file():
        return {"rows": [], "hot_spot_fraction": None, "gap_fraction": None}
    doc = read_input_json(path, "deposition.json")
    nominal = finite_or_none((doc.get("metrics") or {}).get("nominal_rate_lpha"))
    bands = doc.get("dose_bands") or {}
    judged = bool(bands) and all("faults" in r for r in doc.get("rows") or [])
    rows, hot, gap, total = [], 0.0, 0.0, 0.0
    for r in doc.get("rows") or []:
        mean = finite_or_none(r.get("mean_rate_lpha"))
        rows.append({"row": r.get("row"), "mean_rate_lpha": mean, "covered_fraction": finite_or_none(r.get("covered_fraction")),
                     "rate_ratio": mean / nominal if mean is not None and nominal else None})
        if judged:  # the dose checks' own stretches
            planned = r.get("planned_m") or [0.0, r.get("length_m") or 0.0]
            total += max(0.0, float(planned[1]) - float(planned[0]))
            for f in r["faults"]:
                span = max(0.0, float(f["to_m"]) - float(f["from_m"]))
                hot += span if f.get("kind") == "hot" else 0.0
                gap += span if f.get("kind") == "gap" else 0.0
            continue
        rate = np.asarray(r.get("rate_lpha") or [], dtype=float)
        seg = float(r.get("segment_m") or 0.0)
        if nominal and rate.size and seg > 0:
            lengths = np.full(rate.size, seg)
            lengths[-1] = max(0.0, float(r.get("length_m") or rate.size * seg) - seg * (rate.size - 1))
            hot += float(lengths[rate > HOT_FACTOR * nominal].sum())
            gap += float(lengths[rate < GAP_FACTOR * nominal].sum())
            total += float(lengths.sum())
    listed = _listed_rows(run_dir)
    for r in rows:  # the world's row index as the mission lists it (the deposition counts targets in list order)
        i = r["row"]
        r["label"] = f"row {listed[i]}" if isinstance(i, int) and len(listed) == len(rows) else f"target {i}"
    return {"rows": rows, "nominal_rate_lpha": nominal,
            "hot_factor": float(bands["hot_ratio"]) if judged else HOT_FACTOR,
            "gap_factor": float(bands["gap_ratio"]) if judged else GAP_FACTOR,
            "rate_tolerance": float(bands["rate_tolerance"]) if judged else None,
            "hot_spot_fraction": hot / total if total else None, "gap_fraction": gap / total if total else None}


def _listed_rows(run_dir: Path) -> list[Any]:
    """The row indices the run's first spray phase lists ([] when it targets the world's rows or polylines)."""
    import yaml

    try:
        doc = yaml.safe_load((run_dir / rundir.MISSION).read_text(encoding="utf-8")) or {}
    except (OSError, yaml.YAMLError):
        return []
    for ph in doc.get("phases") or []:
        if isinstance(ph, dict) and ph.get("type") == "spray":
            rows = ph.get("rows")
            return list(rows) if isinstance(rows, list) and all(isinstance(x, int) for x in rows) else []
    return []


def autopilot_figures(run_dir: str | Path) -> dict[str, Any]:
    """The compared figures of one run directory (module docstring); a figure that does not apply is None."""
    run_dir = Path(run_dir)
    s = rundir.read_summary(run_dir)
    m = s.get("metrics") or {}
    events = rundir.read_events(run_dir / rundir.EVENTS)
    ups = [float(e["t_s"]) for e in events if e["kind"] == "liftoff"]
    downs = [float(e["t_s"]) for e in events if e["kind"] == "touchdown"]
    beh: dict[str, Any]
    try:
        beh = behaviour_figures(run_dir)
    except VinecliError as exc:  # e.g. a run whose mission.yaml cannot be read any more: its other figures stand
        beh = {"error": str(exc)}
    dose = dose_figures(run_dir)
    tracking = finite_or_none(m.get("cross_track_rms_m")) if dose["rows"] else None
    if tracking is None:
        tracking = beh.get("hover_error_rms_m")
    fw = s.get("firmware") or {}
    return {
        "run_id": s.get("run_id"), "dir": str(run_dir), "autopilot": s.get("autopilot"),
        "firmware": " ".join(str(x) for x in (fw.get("firmware"), fw.get("version")) if x) or "vinecli built-in",
        "status": s.get("status"), "passed": s.get("passed"),
        "tracking_error_m": tracking,
        "mission_time_s": (downs[-1] - ups[0]) if ups and downs and downs[-1] > ups[0] else None,
        "sim_time_s": finite_or_none(s.get("sim_time_s")), "energy_wh": finite_or_none(m.get("energy_wh")),
        "mean_rate_lpha_on_rows": finite_or_none(m.get("mean_rate_lpha_on_rows")),
        "row_coverage_fraction": finite_or_none(m.get("row_coverage_fraction")),
        "hot_spot_fraction": dose["hot_spot_fraction"], "gap_fraction": dose["gap_fraction"],
        "rows": dose["rows"], "nominal_rate_lpha": dose.get("nominal_rate_lpha"),
        "hot_factor": dose.get("hot_factor"), "gap_factor": dose.get("gap_factor"),
        "rate_tolerance": dose.get("rate_tolerance"),
        "dose_checks_passed": _dose_verdict(s),
        "behaviour": beh,
    }


def _dose_verdict(summary: dict[str, Any]) -> bool | None:
    """True when every default dose check of the run passed (None: it has none)."""
    from vinecli.missions.dose import DOSE_CHECKS

    got = [c for c in summary.get("checks") or [] if c.get("name") in DOSE_CHECKS]
    return all(bool(c.get("passed")) for c in got) if got else None


def compare_runs(run_dirs: Sequence[str | Path]) -> dict[str, Any]:
    """The figures of runs of one mission and seed, one per autopilot (``comparison.json``)."""
    runs = [autopilot_figures(d) for d in run_dirs]
    missions = {rundir.read_summary(Path(r["dir"])).get("mission") for r in runs}
    seeds = {rundir.read_summary(Path(r["dir"])).get("seed") for r in runs}
    return {"schema": "vinecli.autopilot-comparison/1", "mission": "/".join(sorted(str(x) for x in missions)),
            "seed": next(iter(seeds)) if len(seeds) == 1 else sorted(seeds), "figures": FIGURES,
            "hot_factor": HOT_FACTOR, "gap_factor": GAP_FACTOR, "runs": runs}


__all__ = ["FIGURES", "GAP_FACTOR", "HOT_FACTOR", "autopilot_figures", "compare_runs", "dose_figures"]
