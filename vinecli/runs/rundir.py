"""Writing and reading run directories (docs/architecture.md "Run directory").

``RUNS/<run_id>/``: ``timeseries.parquet`` (SI columns, frame in the name), ``summary.json``,
``events.jsonl``, ``manifest.json``, ``mission.yaml`` (resolved copy), ``terrain_preview.npz``
and optionally ``run.mcap``. Everything is written into a temporary sibling directory and
renamed into place (:func:`vinecli.outputs.atomic_output_dir`).
"""

from __future__ import annotations

import json
import logging
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import InputError, VinecliError
from vinecli.inputs import read_input_text
from vinecli.outputs import jsonable, manifest_problem, write_json

SUMMARY = "summary.json"
TIMESERIES = "timeseries.parquet"
EVENTS = "events.jsonl"
MISSION = "mission.yaml"
PREVIEW = "terrain_preview.npz"
MCAP = "run.mcap"

log = logging.getLogger(__name__)

#: keys a complete summary.json has (used by batch --resume)
SUMMARY_KEYS = ("run_id", "status", "passed", "checks", "sim_time_s")


def write_timeseries(path: Path, columns: Mapping[str, np.ndarray], metadata: Mapping[str, str] | None = None) -> None:
    """Write the time series as one Parquet table (float64/int columns, zstd), the columns in the order the row's
    schema declares (:mod:`vinecli.sim.row`; any it does not declare after them)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    names = schema_order(columns)
    arrays = [pa.array(np.asarray(columns[n])) for n in names]
    table = pa.Table.from_arrays(arrays, names=names)
    if metadata:
        table = table.replace_schema_metadata({k: str(v) for k, v in metadata.items()})
    pq.write_table(table, path, compression="zstd")


def schema_order(names: Iterable[str]) -> list[str]:
    """``names`` in the order of the time-series schema (:func:`vinecli.sim.row.timeseries_columns` for as many
    rotors as they have), any name it does not declare after them in their own order."""
    from vinecli.sim.row import timeseries_columns

    names = list(names)
    rotors = sum(re.fullmatch(r"rotor\d+_w_radps", c) is not None for c in names)
    declared = timeseries_columns(rotors)
    have, known = set(names), set(declared)
    return [c for c in declared if c in have] + [c for c in names if c not in known]


def read_timeseries(path: Path) -> dict[str, np.ndarray]:
    """Read a run's ``timeseries.parquet`` into numpy columns."""
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    return {name: table.column(name).to_numpy() for name in table.column_names}


def write_events(path: Path, events: Sequence[Any]) -> None:
    """One JSON object per line: ``{t_s, kind, message, data}``."""
    with open(path, "w", encoding="utf-8") as f:
        for ev in events:
            rec = {"t_s": ev.t_us / 1e6, "kind": ev.kind, "message": ev.message, "data": jsonable(dict(ev.data))}
            f.write(json.dumps(rec, allow_nan=False) + "\n")


def read_events(path: Path) -> list[dict[str, Any]]:
    """Events of a run as dicts."""
    path = Path(path)
    if not path.exists():
        return []
    try:
        events = [json.loads(line) for line in read_input_text(path, "events.jsonl").splitlines() if line.strip()]
    except json.JSONDecodeError as exc:
        raise InputError(f"corrupt events.jsonl (line {exc.lineno})", path=path) from None
    if not all(isinstance(e, dict) for e in events):
        raise InputError("corrupt events.jsonl (an event is not a mapping)", path=path)
    return events


def write_preview(path: Path, preview: Mapping[str, Any] | None) -> None:
    """Terrain preview for plots: ``x``, ``y`` (1-D, m ENU) and ``z`` (2-D, m), empty arrays if absent."""
    p = dict(preview or {})
    np.savez_compressed(
        path,
        x=np.asarray(p.get("x", np.zeros(0)), dtype=float),
        y=np.asarray(p.get("y", np.zeros(0)), dtype=float),
        z=np.asarray(p.get("z", np.zeros((0, 0))), dtype=float),
    )


def write_summary(path: Path, summary: Mapping[str, Any]) -> None:
    write_json(path, summary)


def read_summary(run_dir: Path) -> dict[str, Any]:
    """``summary.json`` of a run directory; InputError if missing or invalid."""
    p = Path(run_dir) / SUMMARY
    if not p.exists():
        raise InputError("not a run directory (no summary.json)", path=run_dir)
    try:
        doc = json.loads(read_input_text(p, SUMMARY))
    except json.JSONDecodeError as exc:
        raise InputError(f"unreadable summary.json: {exc}", path=run_dir) from None
    if not isinstance(doc, dict):
        raise InputError(f"corrupt summary.json: expected a mapping, got {type(doc).__name__}", path=run_dir)
    return doc


def is_complete_run(run_dir: Path) -> bool:
    """True if ``run_dir`` holds a finished run: summary.json with every key, not interrupted, and every file
    the manifest lists (summary.json among them) present with its recorded size and sha256."""
    try:
        s = json.loads(read_input_text(Path(run_dir) / SUMMARY, SUMMARY))
    except (InputError, json.JSONDecodeError):
        return False
    if not isinstance(s, dict) or not all(k in s for k in SUMMARY_KEYS) or s.get("status") in ("interrupted", "running"):
        return False
    problem = manifest_problem(Path(run_dir))
    if problem is not None:
        log.info("run %s is incomplete: %s", run_dir, problem)
        return False
    return True


def world_gravity(summary: Mapping[str, Any]) -> float | None:
    """Gravity (m/s², positive) of the world a run flew in (summary.json ``world.dir``), or None when that
    world is not available here (moved, deleted, unreadable)."""
    try:
        from vinecli.world import load_world

        return float(load_world(Path(summary["world"]["dir"])).gravity)
    except (KeyError, TypeError, VinecliError):
        return None
