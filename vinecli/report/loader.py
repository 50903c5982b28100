"""Finding and validating the runs a report reads (docs/architecture.md "Run directory").

``RUNS`` is either a batch (``RUNS/batch.json`` listing the cases), a directory of run
directories (each with ``summary.json``), or one run directory. Every run is validated
up front (summary keys, ``timeseries.parquet`` footer, ``events.jsonl`` lines) so a bad
input fails with one :class:`~vinecli.errors.InputError` naming the run before anything
is written. Time series are read lazily, only the columns a figure needs.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError
from vinecli.inputs import read_input_text, require_regular_file
from vinecli.missions.metrics import airborne_mask
from vinecli.names import check_name
from vinecli.outputs import MANIFEST
from vinecli.runs.batch_json import BATCH_JSON, read_batch_json
from vinecli.runs.failsafes import describe_failsafes
from vinecli.runs.rundir import EVENTS, PREVIEW, SUMMARY, SUMMARY_KEYS, TIMESERIES

log = logging.getLogger(__name__)

#: summary.json keys a run must have for the report: those of a complete run, and its mission
REQUIRED_KEYS = (*SUMMARY_KEYS, "mission")
#: check keys the report shows
CHECK_KEYS = ("name", "op", "bound", "value", "passed")
#: machine-dependent figures: summary.json ``timing`` (older runs had them in ``metrics`` / at the top level)
TIMING_KEYS = ("wall_time_s", "real_time_factor", "loop_wall_s", "wall_per_step_us", "cpu_per_step_us",
               "loop_real_time_factor", "deposition_transport_s", "deposition_transport_cpu_s")


@dataclass
class Run:
    """One run (or one batch case that errored before writing a run directory).

    ``summary`` is the run's summary.json; ``error`` is the batch's error message for a case
    that could not run (then ``dir`` may be None and ``summary`` is synthesised from batch.json).
    """

    case: str
    run_id: str
    dir: Path | None
    summary: dict[str, Any]
    error: str | None = None
    columns: list[str] = field(default_factory=list)
    report_metrics: dict[str, float | None] = field(default_factory=dict)

    @property
    def mission(self) -> str:
        return str(self.summary.get("mission") or "?")

    @property
    def status(self) -> str:
        return "error" if self.error else str(self.summary.get("status"))

    @property
    def checks(self) -> list[dict[str, Any]]:
        return list(self.summary.get("checks") or [])

    @property
    def failed_checks(self) -> list[dict[str, Any]]:
        return [c for c in self.checks if not c.get("passed")]

    @property
    def passed(self) -> bool:
        return self.error is None and bool(self.summary.get("passed")) and not self.failed_checks

    @property
    def errored(self) -> bool:
        return self.error is not None

    def metrics(self) -> dict[str, float | None]:
        """summary.json metrics plus the ones the report derives (``max_tilt_deg``); timing figures excluded."""
        m = {k: v for k, v in (self.summary.get("metrics") or {}).items() if k not in TIMING_KEYS}
        return {**m, **self.report_metrics}

    @property
    def timing(self) -> dict[str, Any]:
        """summary.json ``timing`` (wall_time_s, real_time_factor, µs per step); older runs: top-level keys."""
        out: dict[str, Any] = {k: self.summary[k] for k in ("wall_time_s", "real_time_factor") if k in self.summary}
        t = self.summary.get("timing")
        if isinstance(t, dict):
            out.update(t)
        return out

    @property
    def failsafes(self) -> list[dict[str, Any]]:
        """summary.json ``failsafes`` ([{t_s, cause, action, detail, position_enu}], [] when none)."""
        fs = self.summary.get("failsafes")
        return [f for f in fs if isinstance(f, dict)] if isinstance(fs, list) else []

    @property
    def failsafe_text(self) -> str:
        """The failsafes in one line, e.g. "geofence breach at 10.06 s → hold; sprayer off" ('' when none)."""
        return describe_failsafes(self.failsafes)

    def read_columns(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        """The named time-series columns that exist (float arrays); ``t_s`` always included."""
        import pyarrow.parquet as pq

        if self.dir is None:
            return {}
        want = ["t_s", *[n for n in names if n in self.columns and n != "t_s"]]
        try:
            table = pq.read_table(self.dir / TIMESERIES, columns=want)
        except Exception as exc:  # noqa: BLE001 - pyarrow raises many types for corrupt files
            raise InputError(f"corrupt run: cannot read {TIMESERIES} ({exc})", path=self.dir) from None
        return {n: np.asarray(table.column(n).to_numpy(zero_copy_only=False), dtype=float) for n in want}

    def events(self) -> list[dict[str, Any]]:
        if self.dir is None or not (self.dir / EVENTS).is_file():
            return []
        return _read_events(self.dir / EVENTS)

    def preview(self) -> dict[str, np.ndarray] | None:
        """Terrain preview (x, y 1-D; z[y, x]) or None when absent/empty."""
        if self.dir is None or not (self.dir / PREVIEW).is_file():
            return None
        try:
            with np.load(self.dir / PREVIEW) as z:
                p = {k: np.asarray(z[k], dtype=float) for k in ("x", "y", "z")}
        except (OSError, ValueError, KeyError) as exc:
            raise InputError(f"corrupt run: cannot read {PREVIEW} ({exc})", path=self.dir) from None
        if p["z"].size == 0 or p["z"].shape != (p["y"].size, p["x"].size):
            return None
        return p


def load_runs(runs_dir: str | Path) -> list[Run]:
    """All runs under ``runs_dir`` (batch order when there is a batch.json, else sorted by name).

    Raises InputError (exit 2) naming the runs directory or the bad run.
    """
    root = Path(runs_dir)
    if not root.is_dir():
        raise InputError("not a runs directory (does not exist or is not a directory)", path=root)
    if (root / SUMMARY).is_file():
        runs = [load_run(root, None)]
    elif (root / BATCH_JSON).is_file():
        runs = _from_batch(root)
    else:
        dirs = sorted(p.parent for p in root.glob(f"*/{SUMMARY}")
                      if not p.parent.name.startswith((".", "_")) and not _is_report_dir(p.parent))
        if not dirs:
            raise InputError("not a runs directory (no batch.json and no run directories with summary.json)",
                             path=root)
        runs = [load_run(d, None) for d in dirs]
    if not runs:
        raise InputError("the batch lists no cases", path=root / BATCH_JSON)
    seen: dict[str, str] = {}
    for r in runs:
        if r.case in seen:
            raise InputError(f"case name {r.case!r} appears twice (runs {seen[r.case]} and {r.run_id})", path=root)
        seen[r.case] = r.run_id
    log.info("loaded %d runs from %s", len(runs), root)
    return runs


def _from_batch(root: Path) -> list[Run]:
    p = root / BATCH_JSON
    cases = read_batch_json(p)["cases"]
    runs = []
    for i, c in enumerate(cases):
        if not isinstance(c, dict) or "run_id" not in c:
            raise InputError(f"corrupt batch.json: case #{i} has no run_id", path=p)
        run_id = check_name(str(c["run_id"]), f"batch.json case #{i}: run_id", path=p)  # never a path elsewhere
        case = str(c.get("case") or run_id)
        d = root / run_id
        if c.get("error") or c.get("status") in ("error", "pending"):
            msg = str(c.get("error") or f"case {c.get('status')}: not run")
            summary = {"run_id": run_id, "case": case, "mission": _mission_of(d, case), "status": "error",
                       "status_message": msg, "passed": False, "checks": [], "sim_time_s": c.get("sim_time_s", 0.0),
                       "seed": c.get("seed"), "metrics": {}}
            runs.append(Run(case=case, run_id=run_id, dir=None, summary=summary, error=msg))
            continue
        if not (d / SUMMARY).is_file():
            raise InputError(f"run {run_id!r} listed in batch.json is missing (no {SUMMARY})", path=d)
        runs.append(load_run(d, case))
    return runs


def _is_report_dir(d: Path) -> bool:
    """A ``vinecli report`` output (its own summary.json) placed inside the runs directory."""
    try:
        return json.loads(read_input_text(d / MANIFEST, MANIFEST)).get("command") == "report"
    except (InputError, ValueError, AttributeError):
        return False


def _mission_of(d: Path, fallback: str) -> str:
    try:
        return str(json.loads(read_input_text(d / SUMMARY, SUMMARY)).get("mission") or fallback)
    except (InputError, json.JSONDecodeError, AttributeError):
        return fallback


def load_run(d: Path, case: str | None = None) -> Run:
    """One run directory, validated (summary keys, time-series footer, event lines): InputError naming it when
    something is missing or corrupt. ``case``: the batch's case name (default: the summary's, else the run id)."""
    import pyarrow.parquet as pq

    if not (d / SUMMARY).exists():
        raise InputError(f"missing {SUMMARY}", path=d)
    try:
        summary = json.loads(read_input_text(d / SUMMARY, SUMMARY))
    except json.JSONDecodeError as exc:
        raise InputError(f"corrupt run: unreadable {SUMMARY} ({exc})", path=d) from None
    if not isinstance(summary, dict):
        raise InputError(f"corrupt run: {SUMMARY} is not an object", path=d)
    missing = [k for k in REQUIRED_KEYS if k not in summary]
    if missing:
        raise InputError(f"corrupt run: {SUMMARY} lacks {', '.join(missing)}", path=d)
    if not isinstance(summary["checks"], list):
        raise InputError(f"corrupt run: {SUMMARY} 'checks' is not a list", path=d)
    for i, c in enumerate(summary["checks"]):
        if not isinstance(c, dict) or any(k not in c for k in CHECK_KEYS):
            raise InputError(f"corrupt run: check #{i} in {SUMMARY} lacks one of {', '.join(CHECK_KEYS)}", path=d)
    for name in (TIMESERIES, EVENTS):
        if not (d / name).exists():
            raise InputError(f"missing {name}", path=d)
        require_regular_file(d / name, name)
    try:
        schema = pq.read_schema(d / TIMESERIES)
    except Exception as exc:  # noqa: BLE001 - ArrowInvalid, OSError...
        raise InputError(f"corrupt run: cannot read {TIMESERIES} ({exc})", path=d) from None
    columns = list(schema.names)
    if "t_s" not in columns:
        raise InputError(f"corrupt run: {TIMESERIES} has no t_s column", path=d)
    try:
        _read_events(d / EVENTS)
    except InputError as exc:
        raise InputError(exc.problem, path=d) from None
    run = Run(case=str(case or summary.get("case") or summary["run_id"]), run_id=str(summary["run_id"]), dir=d,
              summary=summary, columns=columns)
    return run


def _read_events(path: Path) -> list[dict[str, Any]]:
    out = []
    for n, line in enumerate(read_input_text(path, EVENTS).splitlines(), 1):
        if not line.strip():
            continue
        try:
            ev = json.loads(line)
        except json.JSONDecodeError as exc:
            raise InputError(f"corrupt run: {EVENTS} line {n} is not JSON ({exc.msg})", path=path) from None
        if not isinstance(ev, dict) or "t_s" not in ev or "kind" not in ev:
            raise InputError(f"corrupt run: {EVENTS} line {n} lacks t_s/kind", path=path)
        out.append(ev)
    return out


def compute_report_metrics(run: Run) -> dict[str, float | None]:
    """Metrics the report derives from the time series for baselines: ``max_tilt_deg`` (airborne), deg."""
    if run.dir is None:
        return {}
    cols = run.read_columns(["tilt_rad", "on_ground"])
    out: dict[str, float | None] = {"max_tilt_deg": None}
    tilt = cols.get("tilt_rad")
    if tilt is not None and tilt.size:
        air = airborne_mask(cols)
        sel = tilt[air & np.isfinite(tilt)]
        if sel.size:
            v = float(np.degrees(np.max(sel)))
            out["max_tilt_deg"] = v if math.isfinite(v) else None
    return out
