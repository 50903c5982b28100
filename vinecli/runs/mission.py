"""``run_mission``: one mission in one built world -> one run directory.

Reads the mission (and the vehicle it names) once (:func:`~vinecli.missions.spec_io.read_mission`),
loads the world, resolves the run once (:func:`vinecli.sim.setup.prepare_run`: overrides, vehicle,
rows, spray rates, spawn, URDF), makes the autopilot through the registry, runs THE loop
(:func:`vinecli.sim.runner.simulate`), evaluates the checks and writes
``RUNS/<run_id>/`` atomically. Ctrl-C (SIGINT) while running stops the loop at the next step
and the partial run is written with status ``interrupted``; a second Ctrl-C aborts at once. SIGTERM (a CI
runner's timeout, ``kill``) does the same, so the partial run is kept; the CLI then exits 143 (130 for Ctrl-C).
"""

from __future__ import annotations

import logging
import math
import signal
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vinecli import native
from vinecli.constants import MAX_SEED, STANDARD_GRAVITY
from vinecli.errors import InputError, RuntimeFailure, SpecError, VinecliError
from vinecli.inputs import note_input, reading_inputs
from vinecli.locks import output_lock
from vinecli.missions.checks import evaluate_checks
from vinecli.missions.dose import default_checks
from vinecli.missions.job import sorties as job_sorties
from vinecli.missions.metrics import METRICS
from vinecli.missions.quantities import check_quantities
from vinecli.missions.rundata import EventMissing, MetricContext, RunData
from vinecli.missions.spec_io import dump_mission, load_mission, read_mission
from vinecli.names import check_name
from vinecli.outputs import Manifest, atomic_output_dir, check_output_target, contained_path, output_folder
from vinecli.runs import rundir
from vinecli.runs.as_applied_run import as_applied_for
from vinecli.runs.failsafes import describe_failsafes, failsafes_from_events
from vinecli.specs.mission import MissionSpec, SprayPhase, phase_rows

if TYPE_CHECKING:
    from vinecli.runs.as_applied_out import DoseOutputs
    from vinecli.runs.budget_out import BudgetOutputs
    from vinecli.runs.request import RunRequest
    from vinecli.sim.result import SimResult
    from vinecli.sim.setup import PreparedRun
    from vinecli.sitl.record import FirmwareRecord

log = logging.getLogger(__name__)

#: metrics always computed into summary.json (NaN -> null when not applicable)
SUMMARY_METRICS = (
    "tank_force_rest_ratio", "liftoff_force_jump_ratio", "climb_tank_force_ratio", "drag_opposes_vertical_motion",
    "drain_time_ratio", "rotor_mass_correlation", "cross_track_rms_m", "hpos_error_max_m",
    "rotor_wind_period_ratio", "tilt_into_wind_ratio",
    "sorties", "job_time_s", "rows_sprayed_fraction", "area_rate_ha_per_h", "litres_per_sortie",
)


@dataclass
class RunSummary:
    """Small, picklable result of one run (what batch workers send back)."""

    run_id: str
    run_dir: str
    mission: str
    status: str
    passed: bool
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    real_time_factor: float = 0.0
    checks: list[dict[str, Any]] = field(default_factory=list)
    metrics: dict[str, float | None] = field(default_factory=dict)
    status_message: str = ""
    error: str | None = None
    stop_signal: int = 0  # the signal that stopped the run (SIGINT 2, SIGTERM 15), 0 if none

    @property
    def failed_checks(self) -> list[dict[str, Any]]:
        return [c for c in self.checks if not c["passed"]]

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class _StopFlag:
    """SIGINT/SIGTERM -> stop at the next step; wall-clock deadline; optional caller predicate."""

    def __init__(self, deadline: float | None, extra: Callable[[], bool] | None) -> None:
        self.interrupted = False
        self.signum = 0  # the signal that stopped the run (0: none)
        self.timed_out = False
        self.deadline = deadline
        self.extra = extra

    def __call__(self) -> bool:
        if self.deadline is not None and time.monotonic() > self.deadline:
            self.timed_out = True
        return self.interrupted or self.timed_out or bool(self.extra and self.extra())


def default_run_id(mission: MissionSpec, seed: int) -> str:
    """``<mission name>-s<seed>`` (deterministic: re-running the same case replaces its directory)."""
    return f"{mission.name}-s{seed}"


def run_mission(request: RunRequest, *, progress: Callable[[float, float], None] | None = None,
                should_stop: Callable[[], bool] | None = None) -> RunSummary:
    """Run one mission and write its run folder, ``runs_dir/<run_id>/`` (the :class:`RunRequest` says what to run
    and how).

    ``progress`` is called as ``progress(sim_time_s, wall_time_s)`` by the loop; ``should_stop``: an extra stop
    predicate (polled every step). The run holds the lock of its run id from the checks to the write: a second
    writer of the same id exits 2 (``in use by pid N``).

    Returns the :class:`RunSummary`; the run's checks decide ``passed``.
    Raises SpecError/InputError (exit 2) for bad inputs, RuntimeFailure (exit 3) if the loop fails.
    """
    from vinecli.sim.memory import check_run_memory
    from vinecli.sim.setup import RunOverrides, prepare_run
    from vinecli.world import load_world

    seed = request.seed
    with reading_inputs():  # every file the run reads, known before anything is written
        src = read_mission(request.mission)  # the file, its base: chain and the vehicle it names, read here once
        mission_path = src.path
        for p in (mission_path, *request.protect):
            if p is not None:
                note_input(p, "mission")
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
            raise InputError(f"seed: an integer in [0, {MAX_SEED}], got {seed!r}")
        run_id = check_name(request.run_id or default_run_id(src.spec, seed), "run id")
        runs_dir = Path(request.runs_dir)
        out = contained_path(runs_dir, run_id)
        world = load_world(Path(request.world_dir))
        check_output_target(out, overwrite=request.overwrite, kind="run mission")
        overrides = RunOverrides(autopilot=request.autopilot, truth=request.truth, record_rate_hz=request.record_rate)
        with output_folder(runs_dir, "runs"), output_lock(out), \
                prepare_run(world, src.spec, vehicle=src.vehicle, overrides=overrides, source=mission_path) as run:
            check_run_memory(run.mission, run.vehicle, run.world, path=mission_path or run.mission.name,
                             config=run.deposition_config)
            check_quantities(run.mission.checks, mission_path or run.mission.name, n_rotors=run.vehicle.n_rotors)
            flown = _fly(run, request, mission_path, progress, should_stop)
            try:
                return _write_run(run, request, flown, out, mission_path)
            finally:
                if flown.record is not None:
                    flown.record.discard()


@dataclass(frozen=True)
class _Flown:
    """A flown run before its checks and its folder: what the loop returned, the firmware's record (its identity
    and kept logs, amended with what they say), when and how long it flew, and what stopped it."""

    result: SimResult
    record: FirmwareRecord | None
    started_utc: str
    wall_s: float
    stop: _StopFlag


def _fly(run: PreparedRun, request: RunRequest, mission_path: Path | None,
         progress: Callable[[float, float], None] | None, should_stop: Callable[[], bool] | None) -> _Flown:
    """Make the run's autopilot, fly the prepared run with it (:func:`vinecli.sim.runner.simulate`) and close it."""
    from vinecli.sim.runner import simulate
    from vinecli.sitl.options import make_run_autopilot
    from vinecli.sitl.record import firmware_record

    ap = make_run_autopilot(run.mission.autopilot, request.autopilot_options)
    timeout = request.wall_timeout_s
    stop = _StopFlag(time.monotonic() + timeout if timeout else None, should_stop)
    started = datetime.now(UTC).isoformat(timespec="seconds")
    t0 = time.perf_counter()
    on_progress = None
    if progress is not None:
        def on_progress(sim_t: float, _max_t: float) -> None:
            progress(sim_t, time.perf_counter() - t0)
    with _stop_signals_to_flag(stop):
        try:
            result = simulate(run, ap, seed=request.seed, on_progress=on_progress, should_stop=stop)
        except VinecliError:
            raise
        except Exception as exc:  # noqa: BLE001 - any engine failure becomes one exit-3 line
            raise RuntimeFailure(f"simulation failed: {type(exc).__name__}: {exc}", path=mission_path) from exc
        finally:
            close = getattr(ap, "close", None)
            if close is not None:
                close()
    wall = time.perf_counter() - t0
    record = firmware_record(ap)
    if record is not None:
        record.amend(result.metrics, result.events)  # what the firmware's own logs say about the firmware
    return _Flown(result, record, started, wall, stop)


@dataclass(frozen=True)
class _Folder:
    """What a run folder holds besides the flown run: its manifest, summary.json, and the deposition and spray
    budget documents of a spraying run, the as-applied outputs of a run with segment rates."""

    manifest: Manifest
    summary: dict[str, Any]
    deposition: dict[str, Any] | None
    budget: BudgetOutputs | None
    dose: DoseOutputs | None


def _write_run(run: PreparedRun, request: RunRequest, flown: _Flown, out: Path, mission_path: Path | None
               ) -> RunSummary:
    """Checks, summary and the run folder ``out`` of a flown run (:func:`run_mission`)."""
    spec, world, vehicle, result, wall = run.mission, run.world, run.vehicle, flown.result, flown.wall_s
    run_id = out.name  # the run folder is named after its run id
    status = _status_name(result.status)
    status_message = result.detail or _status_message(result.status)
    if flown.stop.timed_out and status == "interrupted":
        status_message = f"stopped: wall-clock limit of {request.wall_timeout_s:g} s reached"
    elif flown.stop.signum and status == "interrupted":
        status_message = f"stopped by {signal.Signals(flown.stop.signum).name}"
    failsafes = failsafes_from_events(result.events)
    if failsafes:
        status_message = f"{status_message} (failsafe: {describe_failsafes(failsafes)})"

    rows = _rows_for_metrics(spec, world.vine_rows_enu)
    dep_metrics: dict[str, float] = {}
    dep_doc: dict[str, Any] | None = None
    budget: BudgetOutputs | None = None
    spray: dict[str, Any] = {}
    if result.deposition is not None:  # spray deposition (docs/deposition.md)
        from vinecli.runs.budget_out import evaluate_budget
        from vinecli.runs.deposition_out import evaluate_deposition

        dep_metrics, dep_doc = evaluate_deposition(result.deposition, run.flight, vehicle, world, rows, run.geofence)
        all_rows = [[tuple(q) for q in r] for r in world.vine_rows_enu] or rows
        budget = evaluate_budget(result.deposition, world, all_rows, dep_metrics.get("nominal_rate_lpha", math.nan))
        dep_metrics.update(budget.metrics)
    dose = as_applied_for(run, result, dep_metrics, dep_doc)  # segment rates flown: the as-applied log (docs/dose.md)
    if any(isinstance(p, SprayPhase) for p in spec.phases):  # did every vine get its dose, and where not
        from vinecli.runs.deposition_out import world_row
        from vinecli.runs.spray_report import describe_spray, judge_ending, locate_cutouts, locate_faults

        phase = next((p for p in run.flight.phases if isinstance(p, SprayPhase)), None)  # rows named as the world's
        dep_rows = [{**r, "world_row": world_row(phase, r["row"])} for r in dep_doc["rows"]] if dep_doc is not None else None
        status, status_message = judge_ending(status, status_message, spec, dep_rows, result.timeseries)
        from vinecli.missions.job import operations

        spray = {"operations": operations(result.timeseries, [(e.t_us * 1e-6, e.kind, e.data) for e in result.events],
                                          float(dep_metrics.get("treated_area_ha", math.nan))),
                 "dose_faults": locate_faults(dep_rows or [], result.timeseries),
                 "sprayer_cutouts": locate_cutouts([(e.t_us * 1e-6, e.kind, e.data) for e in result.events],
                                                   dep_rows or [], 0.5 * float(dep_metrics.get("spray_track_width_m", 1.0)),
                                                   result.timeseries)}
        if dep_doc is not None:
            dep_doc.update(spray)
        note = describe_spray(spray["dose_faults"], spray["sprayer_cutouts"])
        status_message = f"{status_message} ({note})" if note else status_message
    data = RunData(
        timeseries=result.timeseries,
        events=[(ev.t_us / 1e6, ev.kind) for ev in result.events],
        status=status,
        metrics={**result.metrics, **dep_metrics},
        context=MetricContext(gravity=float(world.gravity), rows_enu=rows),
    )
    checks = evaluate_checks(spec.checks, data, default_checks(spec, dep_metrics))
    passed = all(c.passed for c in checks)
    metrics = _summary_metrics(data)
    sim_time = float(result.sim_time_s)
    rtf = sim_time / wall if wall > 0 else 0.0
    world_dir = Path(request.world_dir)
    summary = {
        "run_id": run_id,
        "case": request.case or run_id,
        "mission": spec.name,
        "description": spec.description,
        "vehicle": vehicle.name,
        # a fitted vehicle (vinecli vehicle fit): its log, firmware, date and replay errors; None otherwise
        "vehicle_fit": vehicle.provenance.model_dump(mode="json") if vehicle.provenance is not None else None,
        "world": _world_doc(run, world_dir),
        "autopilot": spec.autopilot,
        "firmware": flown.record.summary() if flown.record is not None else None,
        "truth": spec.truth,
        "seed": request.seed,
        "status": status,
        "status_message": status_message,
        "passed": passed,
        "sim_time_s": sim_time,
        "record_rate_hz": spec.record_rate_hz,
        "failsafes": failsafes,
        "checks": [c.to_dict() for c in checks],
        "metrics": metrics,
        "sorties": job_sorties(result.timeseries, [(e.t_us * 1e-6, e.kind, e.data) for e in result.events]),
        **spray,
        "timing": _timing_doc(result.timing, wall, rtf),
        "started_utc": flown.started_utc,
        "kernel": native.identity(),  # which kernel ran: compiled or pure, and its build identity
    }
    manifest = Manifest(
        command="run mission",
        parameters={"seed": request.seed, "autopilot": spec.autopilot, "truth": spec.truth,
                    **request.autopilot_options.changed(), "record_rate_hz": spec.record_rate_hz, "mcap": request.mcap,
                    "run_id": run_id},
        inputs=[p for p in (mission_path, world_dir / "world.json") if p is not None],
        timings={"simulate": round(wall, 4)},
        extra={"status": status},
    )
    _write_run_dir(out, run, request, flown, _Folder(manifest, summary, dep_doc, budget, dose))
    log.info("run %s: %s, %d/%d checks passed", run_id, status, sum(c.passed for c in checks), len(checks))
    return RunSummary(
        run_id=run_id, run_dir=str(out), mission=spec.name, status=status, passed=passed, sim_time_s=sim_time,
        wall_time_s=round(wall, 4), real_time_factor=round(rtf, 3), checks=summary["checks"], metrics=metrics,
        status_message=status_message, stop_signal=flown.stop.signum,
    )


def _world_doc(run: PreparedRun, world_dir: Path) -> dict[str, Any]:
    """summary.json's ``world``: name, directory, geodetic origin, rows, the run's geofence."""
    world, geofence = run.world, run.geofence
    return {
        "name": world.name,
        "dir": str(world_dir.resolve()),
        "origin": world.origin.to_dict(),
        "rows_enu": [[list(p) for p in row] for row in world.vine_rows_enu],
        "geofence": geofence.model_dump(mode="json") if geofence is not None else None,
    }


def _timing_doc(loop: dict[str, float], wall: float, rtf: float) -> dict[str, float | None]:
    """summary.json's ``timing``: machine-dependent, kept out of the (deterministic) metrics."""
    return {"wall_time_s": round(wall, 4), "real_time_factor": round(rtf, 3),
            **{k: _num(v) for k, v in loop.items() if k != "real_time_factor"},
            "loop_real_time_factor": _num(loop.get("real_time_factor"))}


def _write_run_dir(out: Path, run: PreparedRun, request: RunRequest, flown: _Flown, folder: _Folder) -> None:
    """Write the run folder ``out`` atomically: time series, events, the resolved mission, the terrain preview,
    run.mcap (``request.mcap``), the deposition outputs and the spray budget's, a firmware's kept logs, summary.json
    last."""
    spec, result, record, summary, manifest = run.mission, flown.result, flown.record, folder.summary, folder.manifest
    run_id, seed = summary["run_id"], summary["seed"]
    t1 = time.perf_counter()
    with atomic_output_dir(out, manifest, overwrite=request.overwrite) as tmp:
        rundir.write_timeseries(tmp / rundir.TIMESERIES, result.timeseries,
                                {"run_id": run_id, "mission": spec.name, "seed": str(seed), "units": "SI; frame in names"})
        rundir.write_events(tmp / rundir.EVENTS, result.events)
        (tmp / rundir.MISSION).write_text(dump_mission(spec), encoding="utf-8")
        rundir.write_preview(tmp / rundir.PREVIEW, result.terrain_preview)
        if request.mcap:
            from vinecli.runs.mcap_out import write_mcap

            write_mcap(tmp / rundir.MCAP, result.timeseries, result.events)
        if folder.deposition is not None and result.deposition is not None:
            from vinecli.runs.deposition_out import dsm_crs, write_deposition

            crs = dsm_crs(Path(request.world_dir))
            write_deposition(tmp, result.deposition, run.world, crs, folder.deposition)
            if folder.budget is not None:
                from vinecli.runs.budget_out import write_budget

                write_budget(tmp, folder.budget, result.deposition, run.world, crs)
        if record is not None:
            record.copy_into(tmp)
        if folder.dose is not None:  # and its summary.json entry as_applied
            folder.dose.write(tmp, run.world, Path(request.world_dir), summary)
        rundir.write_summary(tmp / rundir.SUMMARY, summary)
        manifest.timings["write"] = round(time.perf_counter() - t1, 4)


def _summary_metrics(data: RunData) -> dict[str, float | None]:
    """The metrics summary.json records (NaN -> None): the simulator's and the deposition model's, the event
    times as the checks see them (first event, else the simulator metric) and :data:`SUMMARY_METRICS`."""
    metrics: dict[str, float | None] = {k: _num(v) for k, v in data.metrics.items()}
    for kind in ("liftoff", "tank_empty"):
        try:
            metrics[f"{kind}_s"] = data.event_time(kind)
        except EventMissing:
            metrics.setdefault(f"{kind}_s", None)
    for name in SUMMARY_METRICS:
        if name not in metrics:
            try:
                metrics[name] = _num(METRICS[name].fn(data, None))
            except (KeyError, ValueError, IndexError):
                metrics[name] = None
    return metrics


def _rows_for_metrics(spec: MissionSpec, world_rows_enu: Sequence[Sequence[Sequence[float]]]) -> list[list[tuple[float, float]]]:
    """Row polylines (ENU m) the spray metrics compare against: a spray phase's explicit rows, else the world's."""
    world_rows = [list(map(tuple, r)) for r in world_rows_enu or []]
    spray = next((ph for ph in spec.phases if isinstance(ph, SprayPhase)), None)
    return phase_rows(spray, world_rows) if spray is not None else world_rows


def _status_name(status: Any) -> str:
    return str(getattr(status, "value", status))


def _status_message(status: Any) -> str:
    return str(getattr(status, "message", ""))


def _num(v: Any) -> float | None:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


class _stop_signals_to_flag:
    """Context manager: in the main thread, the first SIGINT or SIGTERM sets ``flag.interrupted`` (and
    ``flag.signum``); a second one raises KeyboardInterrupt (abort at once)."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self, flag: _StopFlag) -> None:
        self.flag = flag
        self.old: dict[int, Any] = {}

    def __enter__(self) -> None:
        if threading.current_thread() is not threading.main_thread():
            return

        def handler(signum: int, frame: Any) -> None:
            if self.flag.interrupted:
                raise KeyboardInterrupt
            log.warning("%s: stopping the run at the next step (again to abort)", signal.Signals(signum).name)
            self.flag.interrupted = True
            self.flag.signum = signum

        for sig in self.SIGNALS:
            self.old[sig] = signal.getsignal(sig)
            signal.signal(sig, handler)

    def __exit__(self, *exc: object) -> None:
        for sig, old in self.old.items():
            signal.signal(sig, old)


def recheck_run(run_dir: str | Path, mission: str | Path | MissionSpec | None = None) -> tuple[dict[str, Any], list[Any]]:
    """Evaluate checks again on a finished run directory (nothing is simulated, nothing is written).

    ``mission``: the checks to evaluate (a mission file or spec); default: the run's own ``mission.yaml``.
    Returns (summary.json as a dict, list of :class:`~vinecli.missions.checks.CheckResult`).
    """
    run_dir = Path(run_dir)
    summary = rundir.read_summary(run_dir)
    if mission is None:
        spec = load_mission(run_dir / rundir.MISSION, check_vehicle=False)
    elif isinstance(mission, MissionSpec):
        spec = mission
    else:
        spec = load_mission(mission, check_vehicle=False)
    ts_path = run_dir / rundir.TIMESERIES
    if not ts_path.is_file():
        raise SpecError("run directory has no timeseries.parquet", path=run_dir)
    ts = rundir.read_timeseries(ts_path)
    events = [(float(e["t_s"]), str(e["kind"])) for e in rundir.read_events(run_dir / rundir.EVENTS)]
    world = summary.get("world") or {}
    gravity = STANDARD_GRAVITY
    try:
        from vinecli.world import load_world

        gravity = float(load_world(Path(world["dir"])).gravity)
    except (KeyError, TypeError, VinecliError):
        log.info("world of %s not available: g = %.5f m/s²", run_dir, gravity)
    rows = [[tuple(p) for p in r] for r in world.get("rows_enu") or []]
    data = RunData(
        timeseries=ts, events=events, status=str(summary.get("status")),
        metrics={k: float(v) for k, v in (summary.get("metrics") or {}).items() if isinstance(v, (int, float))},
        context=MetricContext(gravity=gravity, rows_enu=_rows_for_metrics(spec, rows)),
    )
    return summary, evaluate_checks(spec.checks, data, default_checks(spec, data.metrics))
