"""Running missions into run directories (``RUNS/<run_id>/``)."""

from vinecli.runs.mission import RunSummary, recheck_run, run_mission

__all__ = ["RunSummary", "recheck_run", "run_mission"]
