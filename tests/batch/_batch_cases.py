"""Top-level job functions for batch tests (importable by spawned workers and Dask).

``case_light`` writes a real, minimal run directory (summary.json via the run-dir writer) so
``--resume`` has something to find; cases named ``boom*`` raise, ``crash*`` kill their worker
process, ``hang*`` sleep far past the limit.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from vinecli.batch.case import CaseResult
from vinecli.outputs import Manifest, atomic_output_dir
from vinecli.runs import RunRequest, rundir


def case_light(spec: RunRequest) -> CaseResult:
    if spec.case.startswith("boom"):
        raise RuntimeError(f"case {spec.case} exploded")
    if spec.case.startswith("crash"):
        os._exit(13)
    if spec.case.startswith("hang"):
        time.sleep(600)
    out = Path(spec.runs_dir) / spec.run_id
    with atomic_output_dir(out, Manifest(command="test"), overwrite=True) as tmp:
        rundir.write_summary(tmp / rundir.SUMMARY, {
            "run_id": spec.run_id, "status": "completed", "passed": True, "checks": [], "sim_time_s": 1.0,
            "seed": spec.seed, "pid": os.getpid(), "world_dir": spec.world_dir,
        })
    return CaseResult(spec.case, spec.run_id, "completed", True, seed=spec.seed, sim_time_s=1.0)
