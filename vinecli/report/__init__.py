"""Reports of runs for people and for CI (``vinecli report``).

Public API: :func:`build_report` -> :class:`ReportResult`; :func:`load_runs`; :class:`Tolerance`
and :data:`DEFAULT_TOLERANCES` for ``--baseline`` comparisons; the figure functions live in
:mod:`vinecli.report.plots`. The names are imported on first use: the light modules of the package
(:mod:`vinecli.report.text`, what the command line prints with) do not load the report machinery.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from vinecli.report.assemble import FORMATS, ReportResult, build_report
    from vinecli.report.baseline import DEFAULT_TOLERANCES, Tolerance
    from vinecli.report.loader import Run, load_runs

__all__ = ["DEFAULT_TOLERANCES", "FORMATS", "ReportResult", "Run", "Tolerance", "build_report", "load_runs"]

_HOME = {"DEFAULT_TOLERANCES": "baseline", "Tolerance": "baseline", "FORMATS": "build", "ReportResult": "build",
         "build_report": "build", "Run": "loader", "load_runs": "loader"}


def __getattr__(name: str) -> Any:
    if name in _HOME:
        return getattr(import_module(f"vinecli.report.{_HOME[name]}"), name)
    raise AttributeError(f"module 'vinecli.report' has no attribute {name!r}")
