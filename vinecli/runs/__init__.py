"""Running missions into run directories (``RUNS/<run_id>/``)."""

from vinecli.runs.mission import RunSummary, recheck_run, run_mission
from vinecli.runs.request import RunRequest

__all__ = ["RunRequest", "RunSummary", "recheck_run", "run_mission"]
