"""The unit of work of a batch: ``run_one(RunRequest) -> CaseResult``.

``run_one`` is a top-level, picklable function executed in worker processes (local process
pool or Dask workers). A worker keeps one PyBullet client with its world's terrain loaded from one
case to the next (:func:`vinecli.world.engine.reuse_terrain_engines`), never raises, and returns a
small :class:`CaseResult`. A stop of a local pool (its shared flag or a SIGTERM to the
worker, :mod:`vinecli.batch.signals`) ends the run at the next step, written with status ``interrupted``.
"""

from __future__ import annotations

import logging
import os
import time
import traceback
from dataclasses import asdict, dataclass, field
from typing import Any

from vinecli.batch.signals import case_running, worker_should_stop
from vinecli.runs.request import RunRequest

log = logging.getLogger(__name__)


@dataclass
class CaseResult:
    """One batch case as recorded in ``batch.json``."""

    case: str
    run_id: str
    status: str
    passed: bool
    error: str | None = None
    seed: int = 0
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    real_time_factor: float = 0.0
    failed_checks: list[str] = field(default_factory=list)
    skipped: bool = False

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def run_one(request: RunRequest) -> CaseResult:
    """Run one case (a batch's :class:`~vinecli.runs.request.RunRequest`, its case and run id set) into
    ``runs_dir/run_id``; any failure becomes ``status='error'`` with a message."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    t0 = time.perf_counter()
    case, run_id, seed = str(request.case), str(request.run_id), request.seed
    if worker_should_stop():
        return CaseResult(case, run_id, "interrupted", False, "not run: the batch was stopped", seed=seed)
    try:
        from vinecli.runs.mission import run_mission
        from vinecli.world.engine import reuse_terrain_engines

        reuse_terrain_engines()  # a worker keeps its world's terrain loaded from one case to the next

        with case_running():
            s = run_mission(request, should_stop=worker_should_stop)
    except BaseException as exc:  # noqa: BLE001 - a worker reports, it never dies with the case
        if isinstance(exc, KeyboardInterrupt):
            raise
        log.debug("case %s failed:\n%s", case, traceback.format_exc())
        return CaseResult(case, run_id, "error", False, f"{type(exc).__name__}: {exc}", seed=seed,
                          wall_time_s=round(time.perf_counter() - t0, 3))
    error = None
    status = s.status
    if status == "interrupted" and s.status_message.startswith("stopped: wall-clock"):
        status, error = "error", f"timeout: {s.status_message}"
    elif status == "error":  # the run could not fly to its end (a firmware died, a lost link): not a check failure
        error = s.status_message or "the run failed"
    return CaseResult(
        case, run_id, status, s.passed and error is None, error, seed=seed, sim_time_s=s.sim_time_s,
        wall_time_s=s.wall_time_s, real_time_factor=s.real_time_factor,
        failed_checks=[c["name"] for c in s.failed_checks],
    )
