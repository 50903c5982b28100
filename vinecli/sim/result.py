"""What a run of THE loop returns (:class:`SimResult`) and how it is assembled once the loop has ended:
end-of-run metrics, the machine-dependent timing kept apart from them, the last spray group and the
deposition transport, the events in time order."""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from vinecli.autopilot.base import RunStatus
from vinecli.sim.loop import Flight
from vinecli.sim.setup import PreparedRun
from vinecli.types import Event

if TYPE_CHECKING:
    from vinecli.sim.spray_deposit import DepositionResult

__all__ = ["SimResult", "assemble_result"]

log = logging.getLogger(__name__)


@dataclass
class SimResult:
    """Outcome of :func:`~vinecli.sim.runner.run_simulation` (docs/architecture.md)."""

    status: RunStatus
    detail: str
    sim_time_s: float
    wall_time_s: float
    timeseries: dict[str, np.ndarray]
    events: list[Event]
    metrics: dict[str, float]
    terrain_preview: dict[str, np.ndarray]
    #: depth-camera point clouds (t_s, (N, 3) float32 world ENU m), empty when the camera is off
    point_clouds: list[tuple[float, np.ndarray]] = field(default_factory=list)
    #: where the spray landed; None when nothing was sprayed or when off
    deposition: DepositionResult | None = None
    #: machine-dependent figures, not metrics: loop_wall_s, wall_per_step_us, cpu_per_step_us, real_time_factor
    timing: dict[str, float] = field(default_factory=dict)

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else math.inf


#: prefixes of the AutopilotStatus.extra counters a firmware backend reports into the run's metrics
FIRMWARE_METRICS = ("px4_", "ardupilot_")


def _timing(steps: int, sim_time: float, wall_loop0: float, cpu_loop0: float, wall_end: float) -> dict[str, float]:
    """The loop's wall and CPU time per step (machine-dependent, kept out of the metrics)."""
    cpu_end = time.process_time()
    return {
        "loop_wall_s": wall_end - wall_loop0,
        "wall_per_step_us": (wall_end - wall_loop0) / max(steps, 1) * 1e6,
        "cpu_per_step_us": (cpu_end - cpu_loop0) / max(steps, 1) * 1e6,  # process CPU time (robust to load)
        "real_time_factor": sim_time / (wall_end - wall_loop0) if wall_end > wall_loop0 else math.inf,
    }


def assemble_result(flight: Flight, run: PreparedRun, seed: int, wall0: float, wall_loop0: float,
                    cpu_loop0: float) -> SimResult:
    """The :class:`SimResult` of ``flight`` once its loop has ended (module doc); ``wall0`` the run's start,
    ``wall_loop0``/``cpu_loop0`` the loop's (``time.perf_counter()``, ``time.process_time()``)."""
    t_us, steps = flight.t_us, flight.k
    sim_time = t_us * 1e-6
    wall_end = time.perf_counter()
    timing = _timing(steps, sim_time, wall_loop0, cpu_loop0, wall_end)
    metrics, events, physics, battery = flight.metrics, flight.events, flight.physics, flight.battery
    metrics["steps"] = float(steps)
    metrics["final_mass_kg"] = physics.mass_kg()
    metrics["energy_wh"] = physics.energy_j / 3600.0 if battery is not None else math.nan
    metrics["battery_soc_end"] = battery.soc if battery is not None else math.nan
    # firmware counters (px4_stalls, ardupilot_stalls, ..._lockstep_steps...) into the run's metrics
    metrics.update({name: float(v) for name, v in flight.ap_status().extra.items() if name.startswith(FIRMWARE_METRICS)})
    events.append(Event(t_us, "status", flight.detail, {"status": flight.status.value}))
    dep = None
    if flight.groups is not None:  # the last group of a run that ended spraying
        flight.groups.flush()
    emitter = flight.emitter
    if emitter is not None and emitter.rows:  # the sprayer was used
        from vinecli.sim.spray_deposit import deposit

        cpu_dep0 = time.process_time()
        dep = deposit(emitter, run.world, run.vehicle, run.wind, seed, run.deposition_config)
        timing["deposition_transport_s"] = dep.transport_s
        timing["deposition_transport_cpu_s"] = time.process_time() - cpu_dep0
        metrics["deposition_records"] = float(len(emitter.rows))
    events.sort(key=lambda e: e.t_us)
    log.info("run ended at %.3f s: %s (%s); %.1f µs/step", sim_time, flight.status.value, flight.detail,
             timing["wall_per_step_us"])
    return SimResult(status=flight.status, detail=flight.detail, sim_time_s=sim_time, wall_time_s=wall_end - wall0,
                     timeseries=flight.rec.columns_dict(), events=events, metrics=metrics,
                     terrain_preview=run.world.terrain_preview(129), point_clouds=flight.point_clouds, deposition=dep,
                     timing=timing)
