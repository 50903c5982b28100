"""Running missions into run directories (``RUNS/<run_id>/``) and the files in them.

* :mod:`~vinecli.runs.mission`: ``run_mission`` (one mission -> one run directory) and ``recheck_run``.
* :mod:`~vinecli.runs.rundir`: the run directory's file names, writing and reading;
  :mod:`~vinecli.runs.batch_json`: a batch's index, ``batch.json``, and its one reader.
* What a run writes besides its time series: :mod:`~vinecli.runs.deposition_out`, :mod:`~vinecli.runs.budget_out`,
  :mod:`~vinecli.runs.gis_out`, :mod:`~vinecli.runs.mcap_out`; what it says about itself:
  :mod:`~vinecli.runs.spray_report`, :mod:`~vinecli.runs.failsafes`, :mod:`~vinecli.runs.behaviour`,
  :mod:`~vinecli.runs.compare` (autopilots side by side).

May import every floor below it (missions, the simulator, the firmware bridges); not report, batch or the
command line, which read what it writes.
"""

from vinecli.runs.mission import RunSummary, recheck_run, run_mission
from vinecli.runs.request import RunRequest

__all__ = ["RunRequest", "RunSummary", "recheck_run", "run_mission"]
