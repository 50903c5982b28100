"""Batch runs: pipelines of missions and sweeps on a local process pool or Dask."""

from vinecli.batch.case import CaseResult, RunSpec, run_one
from vinecli.batch.pipeline import PipelineSpec, expand_cases, load_pipeline
from vinecli.batch.run import BatchResult, run_batch

__all__ = ["BatchResult", "CaseResult", "PipelineSpec", "RunSpec", "expand_cases", "load_pipeline", "run_batch", "run_one"]
