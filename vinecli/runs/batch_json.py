"""``RUNS/batch.json``, the index of a batch's runs folder: its name and its one reader.

:func:`vinecli.batch.run.run_batch` writes it after every case: ``{pipeline, pipeline_file, executor, workers,
updated_utc, wall_time_s, passed, cases: [{case, run_id, status, passed, error, ...}]}``. The report reads it to
list the runs (and the cases that could not run), the batch before it replaces one; both through
:func:`read_batch_json`, which lives here, below both, so neither imports the other for it.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from vinecli.errors import InputError
from vinecli.inputs import read_input_text

BATCH_JSON = "batch.json"


def read_batch_json(path: str | Path) -> dict[str, Any]:
    """The batch.json at ``path`` as a dict whose ``cases`` is a list. InputError (exit 2) naming the file when it
    is not a regular file, not UTF-8, not JSON or has no list of cases (the cases themselves are the caller's)."""
    p = Path(path)
    try:
        doc = json.loads(read_input_text(p, BATCH_JSON))
        cases = doc["cases"]
        if not isinstance(cases, list):
            raise TypeError("'cases' is not a list")
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise InputError(f"corrupt batch.json: {exc}", path=p) from None
    return doc


__all__ = ["BATCH_JSON", "read_batch_json"]
