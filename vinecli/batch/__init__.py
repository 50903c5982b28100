"""Batch runs: pipelines of missions and sweeps on a local process pool or Dask."""

from vinecli.batch.case import CaseResult, run_one
from vinecli.batch.runner import BatchResult, run_batch
from vinecli.batch.spec import PipelineSpec, expand_cases, load_pipeline

__all__ = ["BatchResult", "CaseResult", "PipelineSpec", "expand_cases", "load_pipeline", "run_batch", "run_one"]
