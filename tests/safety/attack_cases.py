"""Top-level case runners (run_batch run_case=) for the issue-20 signal tests (importable by the workers the fork server starts)."""

from __future__ import annotations

import time
from pathlib import Path

from vinecli.batch.case import CaseResult
from vinecli.outputs import Manifest, atomic_output_dir
from vinecli.runs import RunRequest, rundir


def case_slow_write(spec: RunRequest) -> CaseResult:
    """Writes its run folder slowly: a minute inside the atomic write (its temporary folder exists), then done."""
    with atomic_output_dir(Path(spec.runs_dir) / spec.run_id, Manifest(command="test"), overwrite=True) as tmp:
        rundir.write_summary(tmp / rundir.SUMMARY, {"run_id": spec.run_id, "status": "completed", "passed": True,
                                                   "checks": [], "sim_time_s": 1.0, "seed": spec.seed})
        time.sleep(60.0)
    return CaseResult(spec.case, spec.run_id, "completed", True, seed=spec.seed, sim_time_s=1.0)
