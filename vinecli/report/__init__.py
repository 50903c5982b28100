"""Reports of runs for people and for CI (``vinecli report``).

Public API: :func:`build_report` -> :class:`ReportResult`; :func:`load_runs`; :class:`Tolerance`
and :data:`DEFAULT_TOLERANCES` for ``--baseline`` comparisons; the figure functions live in
:mod:`vinecli.report.plots`. The names are imported on first use, so a figure process that imports
:mod:`vinecli.report.plots` does not load the report builder and its batch machinery.

Reads run directories and ``batch.json`` only through :mod:`vinecli.runs` (their file names and readers). May
import every floor below it; never the batch (the batch imports the report for ``run compare``'s figure).
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["DEFAULT_TOLERANCES", "FORMATS", "ReportResult", "Run", "Tolerance", "build_report", "load_runs"]

_WHERE = {"DEFAULT_TOLERANCES": "baseline", "Tolerance": "baseline", "FORMATS": "assemble",
          "ReportResult": "assemble", "build_report": "assemble", "Run": "loader", "load_runs": "loader"}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(import_module(f"vinecli.report.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'vinecli.report' has no attribute {name!r}")
