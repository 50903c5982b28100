"""Running missions into run directories (``RUNS/<run_id>/``)."""

from vinecli.runs.mission import RunSummary, run_mission

__all__ = ["RunSummary", "run_mission"]
