"""Batch runs: a pipeline's cases (missions and sweeps) on a local process pool or Dask, into one runs folder.

* :mod:`~vinecli.batch.pipeline`: pipeline files -> cases; :mod:`~vinecli.batch.run`: ``run_batch`` (workers,
  resume, ``batch.json``); :mod:`~vinecli.batch.case`: one case in a worker; :mod:`~vinecli.batch.executors`:
  the pools; :mod:`~vinecli.batch.prechecks`: what a batch checks before any case runs;
  :mod:`~vinecli.batch.signals`: SIGTERM/SIGINT.
* :mod:`~vinecli.batch.compare_autopilots`: ``vinecli run compare``, one mission flown by several autopilots.

May import every floor below it, the report included (``run compare`` draws its figure with it); the report
never imports the batch (``batch.json`` is :mod:`vinecli.runs.batch_json`'s).
"""

from vinecli.batch.case import CaseResult, run_one
from vinecli.batch.pipeline import PipelineSpec, expand_cases, load_pipeline
from vinecli.batch.run import BatchResult, run_batch

__all__ = ["BatchResult", "CaseResult", "PipelineSpec", "expand_cases", "load_pipeline", "run_batch", "run_one"]
