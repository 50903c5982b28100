"""``run_batch``: every case of a pipeline, in parallel, into one runs directory.

Cases are submitted to a ``concurrent.futures.Executor`` (local process pool or Dask), at most
``workers`` at a time so a case's wall-clock limit counts from its start. A case that raises,
crashes its worker process or runs past its limit is recorded as an error and the batch goes
on: the limit is enforced cooperatively inside the worker (the loop stops at ``timeout_s``)
and, as a last resort, by the parent, which kills a local pool that stops answering
(``timeout_s`` + grace) and requeues the innocent cases. A case whose worker dies is retried
alone once, so only the culprit is recorded as ``worker crashed``. SIGTERM/SIGINT stop the batch
(:mod:`vinecli.batch.signals`): running cases end as ``interrupted`` partial runs, the others are
recorded ``interrupted`` too, and :attr:`BatchResult.signum` tells the CLI to exit 128 + signal.

Writes ``RUNS/batch.json`` (``{pipeline, cases: [{case, run_id, status, passed, error}]}``).
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import time
from collections import deque
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import ExitStack
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from vinecli.batch.case import CaseResult, run_one
from vinecli.batch.executors import (
    EXECUTORS,
    WORKER_CASES,
    dask_executor,
    local_stop_flag,
    make_local_executor,
    start_fork_server,
)
from vinecli.batch.pipeline import Case, PipelineSpec, expand_cases, load_pipeline, with_world
from vinecli.batch.prechecks import check_case_targets, check_cases_memory, note_case_inputs
from vinecli.batch.signals import BatchInterrupted, StopRequest
from vinecli.errors import InputError, SpecError
from vinecli.inputs import note_input, reading_inputs
from vinecli.locks import output_lock
from vinecli.outputs import contained_path, jsonable, output_folder, remove_stale_temps, write_text_atomic
from vinecli.runs import rundir
from vinecli.runs.batch_json import BATCH_JSON
from vinecli.runs.request import RunRequest
from vinecli.sitl.options import PX4_DEFAULTS, AutopilotOptions
from vinecli.specs.limits import MAX_DURATION_S
from vinecli.specs.mission import MissionSpec

log = logging.getLogger(__name__)

WORLDS_DIR = "_worlds"
#: seconds running cases get to write their partial runs after a stop signal
STOP_GRACE_S = 30.0


@dataclass
class BatchResult:
    """Outcome of a batch: one CaseResult per case (in pipeline order)."""

    pipeline: str
    runs_dir: str
    cases: list[CaseResult] = field(default_factory=list)
    wall_time_s: float = 0.0
    #: the signal (SIGTERM 15, SIGINT 2) that stopped the batch, None if it ran to the end
    signum: int | None = None

    @property
    def n_interrupted(self) -> int:
        return sum(c.status == "interrupted" for c in self.cases)

    @property
    def n_passed(self) -> int:
        return sum(c.passed for c in self.cases)

    @property
    def n_failed(self) -> int:
        """Cases that ran to their end and failed a check (an interrupted case is counted apart)."""
        return sum((not c.passed) and c.error is None and c.status != "interrupted" for c in self.cases)

    @property
    def n_errors(self) -> int:
        """Cases that could not run (raised, crashed their worker, timed out); interrupted ones apart."""
        return sum(c.error is not None and c.status != "interrupted" for c in self.cases)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.cases)


ProgressFn = Callable[[CaseResult, int, int], None]


# parameters: the keyword options of the public batch API, one per `vinecli run batch` option or test hook; they
# travel on as one _Batch (what every case's run gets) and one _Pool (how the cases run)
def run_batch(
    pipeline: str | Path | PipelineSpec,
    runs_dir: str | Path,
    workers: int = 1,
    executor: str = "local",
    scheduler: str | None = None,
    resume: bool = False,
    timeout_s: float | None = None,
    *,
    progress: ProgressFn | None = None,
    run_case: Callable[[RunRequest], CaseResult] = run_one,
    dask_processes: bool = True,
    max_tasks_per_child: int = WORKER_CASES,
    grace_s: float | None = None,
    mcap: bool = False,
    world: str | Path | None = None,
    px4_bin: str | Path | None = None,
    ardupilot_bin: str | Path | None = None,
) -> BatchResult:
    """Run a pipeline's cases; returns the :class:`BatchResult` (also written to ``RUNS/batch.json``).

    ``timeout_s`` (wall seconds per case) overrides the pipeline's. ``run_case`` is the top-level,
    picklable function executed per case (default :func:`~vinecli.batch.case.run_one`). ``world`` (a built
    world dir or a world spec) replaces the pipeline's default world (entries naming their own keep theirs).
    ``px4_bin`` / ``ardupilot_bin`` (or the pipeline's): PX4 / ArduPilot cases start their own SITL process,
    one per case.
    """
    if workers < 1:
        raise InputError(f"--workers must be >= 1, got {workers}")
    if executor not in EXECUTORS:
        raise InputError(f"unknown executor {executor!r} (choose from {', '.join(EXECUTORS)})")
    if scheduler and executor != "dask":
        raise InputError("--scheduler needs --executor dask")
    if timeout_s is not None and not (math.isfinite(timeout_s) and 0 < timeout_s <= MAX_DURATION_S):
        raise InputError(f"--timeout must be a number of seconds in (0, {MAX_DURATION_S:g}], got {timeout_s}")
    runs_dir = Path(runs_dir)
    with reading_inputs():  # every file the batch reads, known before anything is written
        if isinstance(pipeline, PipelineSpec):
            spec, ppath = pipeline, Path.cwd() / "pipeline.yaml"
        else:
            ppath = Path(pipeline)
            spec = load_pipeline(ppath)
        if world is not None:
            if not Path(world).exists():
                raise InputError("world not found", path=world)
            spec = with_world(spec, world)
        cases = expand_cases(spec, ppath)
        ap_opts: dict[str, AutopilotOptions] = {}
        for name, given, piped in (("px4", px4_bin, spec.px4_bin), ("ardupilot", ardupilot_bin, spec.ardupilot_bin)):
            if given is not None or piped is not None:
                pb = Path(given) if given is not None else (ppath.parent / str(piped))
                label = "PX4" if name == "px4" else "ArduPilot"
                if not pb.is_file():
                    raise InputError(f"{label} binary not found ({name}_bin)", path=pb)
                note_input(pb, f"{label} binary")
                ap_opts[name] = AutopilotOptions(**{f"{name}_bin": str(pb.resolve())})
        note_case_inputs(cases, ppath)
        check_case_targets(cases, runs_dir, ppath, batch_json=BATCH_JSON, worlds_dir=WORLDS_DIR, resume=resume)
        with output_folder(runs_dir, "runs"), output_lock(runs_dir, inside=True):
            remove_stale_temps(runs_dir)
            try:
                batch = _Batch(spec, ppath, cases, runs_dir, resume, timeout_s if timeout_s is not None else spec.timeout_s,
                               grace_s, mcap, ap_opts)
                pool = _Pool(run_case, workers, executor, scheduler, dask_processes, max_tasks_per_child)
                return _run(batch, pool, progress)
            finally:  # what workers killed by a second signal left half-written
                remove_stale_temps(runs_dir)


@dataclass(frozen=True)
class _Batch:
    """A batch once its inputs are read: the pipeline (and its file), its cases, the runs folder, and what every
    case's run gets (its wall-clock limit, run.mcap, the firmware binaries of its autopilot)."""

    spec: PipelineSpec
    ppath: Path
    cases: list[Case]
    runs_dir: Path
    resume: bool
    timeout_s: float | None  # wall-clock limit per case, s
    grace_s: float | None  # past the limit, s, before the parent stops a worker (None: max(30 s, limit / 4))
    mcap: bool
    autopilot_options: dict[str, AutopilotOptions]  # per autopilot name

    def request(self, case: Case, world_dir: str) -> RunRequest:
        """The run of ``case`` in the built world ``world_dir``."""
        options = self.autopilot_options.get(str(case.mission.get("autopilot")), PX4_DEFAULTS)
        return RunRequest(MissionSpec.model_validate(case.mission), world_dir, str(self.runs_dir), seed=case.seed,
                          run_id=case.name, case=case.name, mcap=self.mcap, wall_timeout_s=self.timeout_s,
                          overwrite=True, protect=(case.mission_path,), autopilot_options=options)

    @property
    def hard_limit_s(self) -> float | None:
        """Wall seconds after which the parent stops a case's worker (the limit and its grace), None without one."""
        limit = self.timeout_s
        if limit is None:
            return None
        return limit + (self.grace_s if self.grace_s is not None else max(30.0, 0.25 * limit))


@dataclass(frozen=True)
class _Pool:
    """How the cases run: ``run_case`` in ``workers`` processes of the ``executor`` (a local process pool, or Dask at
    ``scheduler`` with ``dask_processes``), a local worker replaced after ``max_tasks_per_child`` cases."""

    run_case: Callable[[RunRequest], CaseResult]
    workers: int
    executor: str
    scheduler: str | None
    dask_processes: bool
    max_tasks_per_child: int


def _run(batch: _Batch, pool: _Pool, progress: ProgressFn | None) -> BatchResult:
    """:func:`run_batch` once its inputs are read and its outputs checked (the runs folder locked)."""
    t0 = time.perf_counter()
    if pool.executor == "local":
        start_fork_server()  # its imports overlap with preparing the worlds
    with StopRequest() as stop:
        worlds: dict[str, str] = {}
        try:
            with stop.interruptible():
                worlds = prepare_worlds(batch.cases, batch.runs_dir)
        except BatchInterrupted:
            log.warning("%s: batch stopped while preparing the worlds", stop.name)
        if stop.signum is None:
            check_cases_memory(batch.cases, worlds, batch.ppath)
        requests = [batch.request(c, worlds.get(c.world, c.world)) for c in batch.cases]

        def execute(todo: Sequence[RunRequest], record: Callable[[CaseResult], None]) -> None:
            _execute(todo, pool, batch.hard_limit_s, record, stop)

        def write(results: dict[str, CaseResult]) -> None:
            _write_batch_json(batch.runs_dir, batch.spec, batch.ppath, pool.executor, pool.workers, requests, results,
                              t0)

        results = _run_cases(requests, batch.runs_dir, batch.resume, stop, progress, execute, write)
    return BatchResult(batch.spec.name, str(batch.runs_dir), [results[str(r.case)] for r in requests],
                       round(time.perf_counter() - t0, 3), stop.signum)


def _run_cases(requests: list[RunRequest], runs_dir: Path, resume: bool, stop: StopRequest,
               progress: ProgressFn | None,
               execute: Callable[[Sequence[RunRequest], Callable[[CaseResult], None]], None],
               write: Callable[[dict[str, CaseResult]], None]) -> dict[str, CaseResult]:
    """Resume, ``execute`` and record every case, ``write`` batch.json after each; after a stop signal the
    cases that did not run are recorded as ``interrupted`` so batch.json never keeps a case ``pending``."""
    results: dict[str, CaseResult] = {}
    todo: list[RunRequest] = []
    for rs in requests:
        if resume and rundir.is_complete_run(runs_dir / str(rs.run_id)):
            results[str(rs.case)] = _result_from_summary(rs, runs_dir / str(rs.run_id))
        else:
            todo.append(rs)
    total = len(requests)
    done_count = len(results)
    if results:
        log.info("resume: %d of %d cases already finished", len(results), total)

    def record(r: CaseResult) -> None:
        nonlocal done_count
        results[r.case] = r
        done_count += 1
        if progress is not None:
            progress(r, done_count, total)
        write(results)

    for r in list(results.values()):
        if progress is not None:
            progress(r, list(results).index(r.case) + 1, total)
    try:
        if todo and stop.signum is None:
            execute(todo, record)
    finally:  # also on a second signal (KeyboardInterrupt): batch.json stays consistent
        if stop.signum is not None:
            for rs in requests:
                if rs.case not in results:
                    results[str(rs.case)] = _interrupted(rs, f"not run: the batch was stopped by {stop.name}")
        write(results)
    return results


def _execute(todo: Sequence[RunRequest], pool: _Pool, hard_limit: float | None, record: Callable[[CaseResult], None],
             stop: StopRequest) -> None:
    # longest expected case first (max_duration_s as the estimate): a long case started last would leave
    # the other workers idle at the end of the batch; the order does not change any run (seeds are per case)
    pending: deque[RunRequest] = deque(sorted(todo, key=_expected_cost, reverse=True))
    suspects: deque[RunRequest] = deque()  # cases in flight when a worker died: rerun one at a time
    inflight: dict[Future[CaseResult], tuple[RunRequest, float, bool]] = {}
    run_case, workers, max_tasks_per_child = pool.run_case, pool.workers, pool.max_tasks_per_child
    local = pool.executor == "local"
    flag = local_stop_flag() if local else None
    with ExitStack() as stack:
        if local:
            ex: Executor = make_local_executor(workers, max_tasks_per_child, flag)
        else:
            ex = stack.enter_context(dask_executor(workers, pool.scheduler, processes=pool.dask_processes))

        def refill() -> None:
            while pending and not suspects and len(inflight) < workers:
                s = pending.popleft()
                inflight[ex.submit(run_case, s)] = (s, time.monotonic(), False)

        try:
            while (pending or suspects or inflight) and stop.signum is None:
                while suspects and not inflight:
                    s = suspects.popleft()
                    inflight[ex.submit(run_case, s)] = (s, time.monotonic(), True)
                refill()
                done, _ = wait(list(inflight), timeout=0.5, return_when=FIRST_COMPLETED)
                finished = [(f, inflight.pop(f)) for f in done]
                if not any(isinstance(f.exception(), BrokenProcessPool) for f, _ in finished):
                    refill()  # the freed worker gets its next case before this process writes batch.json
                broken = False
                for f, (s, _t, alone) in finished:
                    try:
                        record(f.result())
                    except BrokenProcessPool:
                        broken = True
                        if alone or len(done) + len(inflight) == 0:
                            record(_error(s, "worker crashed (process died)"))
                        else:
                            suspects.append(s)
                    except Exception as exc:  # noqa: BLE001 - dask KilledWorker, pickling errors...
                        record(_error(s, f"{type(exc).__name__}: {exc}"))
                if broken and local:
                    for f, (s, _t, _a) in list(inflight.items()):  # the rest of the broken pool
                        suspects.append(s)
                        inflight.pop(f)
                    ex.shutdown(wait=False, cancel_futures=True)
                    ex = make_local_executor(workers, max_tasks_per_child, flag)
                if hard_limit is not None:
                    now = time.monotonic()
                    expired = [f for f, (_s, t, _a) in inflight.items() if now - t > hard_limit]
                    for f in expired:
                        s, _t, _a = inflight.pop(f)
                        f.cancel()
                        record(_error(s, f"timeout: no result after {hard_limit:g} s (worker stopped)"))
                    if expired and local:
                        for f, (s, _t, _a) in list(inflight.items()):
                            pending.appendleft(s)
                            inflight.pop(f)
                        _kill_pool(ex)
                        ex = make_local_executor(workers, max_tasks_per_child, flag)
            if stop.signum is not None and inflight:
                _drain(inflight, flag, record, stop.name)
        finally:
            if local:
                if inflight or stop.signum is not None:  # stuck, or stopping: idle workers have nothing to save
                    _kill_pool(ex)
                else:
                    ex.shutdown(wait=True)


def _expected_cost(s: RunRequest) -> float:
    """Simulated seconds a case may take (its mission's ``max_duration_s``), to schedule long cases first."""
    return float(s.mission.max_duration_s) if isinstance(s.mission, MissionSpec) else 0.0


def _drain(inflight: dict[Future[CaseResult], tuple[RunRequest, float, bool]], flag: Any,
           record: Callable[[CaseResult], None], signame: str) -> None:
    """After a stop signal: raise a local pool's stop ``flag`` (its runs end at the next step and are written
    as ``interrupted``), wait up to :data:`STOP_GRACE_S` and record what the cases return (Dask, no flag:
    the running cases are cancelled)."""
    log.info("%s: stopping %d running case(s)", signame, len(inflight))
    if flag is not None:
        flag.value = 1
    done, _ = wait(list(inflight), timeout=STOP_GRACE_S if flag is not None else 0)
    for f in done:
        s, _t, _a = inflight.pop(f)
        try:
            r = f.result()
        except BaseException as exc:  # noqa: BLE001 - a worker that died on the signal
            r = _interrupted(s, f"stopped by {signame}: {type(exc).__name__}")
        record(r)
    for f, (s, _t, _a) in list(inflight.items()):
        f.cancel()
        inflight.pop(f)
        record(_interrupted(s, f"stopped by {signame}: no result after {STOP_GRACE_S:g} s (worker killed)"))


def _interrupted(s: RunRequest, message: str) -> CaseResult:
    return CaseResult(s.case, s.run_id, "interrupted", False, message, seed=s.seed)


def _kill_pool(ex: Executor) -> None:
    """Stop a local process pool now (its workers may be stuck in C code)."""
    procs = list(getattr(ex, "_processes", {}).values())  # ProcessPoolExecutor has no public kill
    for p in procs:
        p.kill()
    ex.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        p.join(timeout=5)


def _error(s: RunRequest, message: str) -> CaseResult:
    return CaseResult(s.case, s.run_id, "error", False, message, seed=s.seed)


def _timing(summary: dict[str, Any]) -> dict[str, Any]:
    """summary.json ``timing`` (older runs: wall_time_s / real_time_factor at the top level)."""
    t = summary.get("timing")
    return t if isinstance(t, dict) else summary


def _result_from_summary(s: RunRequest, run_dir: Path) -> CaseResult:
    d = rundir.read_summary(run_dir)
    return CaseResult(
        s.case, s.run_id, str(d.get("status")), bool(d.get("passed")), None, seed=int(d.get("seed", s.seed)),
        sim_time_s=float(d.get("sim_time_s") or 0.0), wall_time_s=float(_timing(d).get("wall_time_s") or 0.0),
        real_time_factor=float(_timing(d).get("real_time_factor") or 0.0),
        failed_checks=[c["name"] for c in d.get("checks", []) if not c.get("passed")], skipped=True,
    )


def _write_batch_json(runs_dir: Path, spec: PipelineSpec, ppath: Path, executor: str, workers: int,
                      requests: Sequence[RunRequest], results: dict[str, CaseResult], t0: float) -> None:
    cases: list[dict[str, Any]] = []
    for rs in requests:
        r = results.get(rs.case)
        cases.append(r.to_dict() if r else {"case": rs.case, "run_id": rs.run_id, "status": "pending",
                                             "passed": False, "error": None, "seed": rs.seed})
    data = {
        "pipeline": spec.name,
        "pipeline_file": str(ppath),
        "executor": executor,
        "workers": workers,
        "updated_utc": datetime.now(UTC).isoformat(timespec="seconds"),
        "wall_time_s": round(time.perf_counter() - t0, 3),
        "passed": all(c.get("passed") for c in cases),
        "cases": cases,
    }
    write_text_atomic(runs_dir / BATCH_JSON, json.dumps(jsonable(data), indent=2, allow_nan=False) + "\n")


# ---------------------------------------------------------------- worlds
def prepare_worlds(cases: Sequence[Case], runs_dir: Path) -> dict[str, str]:
    """Map each case's world reference to a built world dir, building world specs once into ``RUNS/_worlds/<name>/``."""
    out: dict[str, str] = {}
    for ref in dict.fromkeys(c.world for c in cases):
        p = Path(ref)
        if p.is_dir():
            if not (p / "world.json").is_file():
                raise SpecError("not a built world directory (no world.json)", path=p)
            out[ref] = str(p)
        elif p.suffix in (".yaml", ".yml"):
            out[ref] = str(build_world_once(p, runs_dir / WORLDS_DIR))
        else:
            raise SpecError("a world must be a world spec (.yaml) or a built world directory", path=p)
    return out


def build_world_once(spec_path: Path, worlds_root: Path) -> Path:
    """Build a world spec into ``worlds_root/<stem>/`` unless a build of the same spec is there (the paths
    proven free of symbolic links below the runs folder, the folder replaced only when vinecli made it)."""
    digest = hashlib.sha256(spec_path.read_bytes()).hexdigest()
    out = contained_path(worlds_root.parent, worlds_root.name, spec_path.stem)
    stamp = contained_path(worlds_root.parent, worlds_root.name, f".{spec_path.stem}.spec-sha256")
    if (out / "world.json").is_file() and stamp.is_file() and stamp.read_text().strip() == digest:
        return out
    from vinecli.world import build_world

    log.info("building world %s into %s", spec_path, out)
    with output_folder(worlds_root, "worlds"):
        build_world(spec_path, out, overwrite=True)
        write_text_atomic(stamp, digest + "\n")
    return out
