"""The interface every autopilot backend implements (built-in cascade, PX4 SITL, plugins).

Backends never touch PyBullet: they receive an :class:`~vinecli.types.Observation`
per physics step and return an :class:`~vinecli.types.ActuatorCommand`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Final, Protocol

from vinecli.frames import Vec3
from vinecli.geo import GeoOrigin
from vinecli.specs.mission import GeofenceSpec, MissionSpec
from vinecli.specs.vehicle import VehicleSpec
from vinecli.types import ActuatorCommand, Event, Observation


class RunStatus(str, Enum):  # noqa: UP042 - str() stays "RunStatus.X"; values are used explicitly
    """How a run ended (value = machine name, message = for people)."""

    RUNNING = "running"
    COMPLETED = "completed"
    CANNOT_TAKE_OFF = "cannot_take_off"
    LOST_CONTROL = "lost_control"
    CRASHED = "crashed"
    TIMEOUT = "timeout"
    GEOFENCE_TERMINATED = "geofence_terminated"
    FAILSAFE = "failsafe"
    PREFLIGHT_FAILED = "preflight_failed"
    INTERRUPTED = "interrupted"
    ERROR = "error"
    ABORTED = "aborted"

    @property
    def message(self) -> str:
        return {
            "running": "still running",
            "completed": "all phases completed",
            "cannot_take_off": "cannot take off: thrust-limited (thrust-to-weight below 1)",
            "lost_control": "lost control: attitude beyond the limit",
            "crashed": "crashed into the terrain",
            "timeout": "mission exceeded its time limit",
            "geofence_terminated": "geofence breach: motors terminated",
            "failsafe": "the autopilot left the mission (failsafe or mode change)",
            "preflight_failed": "a preflight check failed: not armed",
            "interrupted": "interrupted by the user",
            "error": "the run failed",
            "aborted": "the mission was abandoned: the job could not be finished",
        }[self.value]


#: ``RunStatus.RUNNING`` as a module constant: the loop and the autopilot test it every step, and an enum
#: class attribute costs ~50 ns on Python 3.11
RUNNING: Final = RunStatus.RUNNING


@dataclass(frozen=True)
class AutopilotContext:
    """Everything a backend needs at reset."""

    mission: MissionSpec
    vehicle: VehicleSpec
    origin: GeoOrigin
    home_enu: Vec3  # m, the spawn point on the terrain (vehicle base position at rest)
    physics_dt_us: int  # physics step, µs
    total_mass_kg: float  # at start (frame + payload + liquid)
    vine_rows_enu: tuple[tuple[tuple[float, float], ...], ...] = ()  # world's rows, polylines (x, y) m
    geofence: GeofenceSpec | None = None
    terrain_height: object = None  # callable (x, y) -> terrain z (ENU, m), or None for flat z = home z
    seed: int = 0
    #: mapped terrain extent (xmin, ymin, xmax, ymax) ENU m; None = unbounded
    terrain_bounds: tuple[float, float, float, float] | None = None
    #: air density of the world, kg/m³ (the spray plan's pattern depends on it through the downwash)
    air_density_kgm3: float = 1.225


@dataclass
class AutopilotStatus:
    """Backend progress: current mode and phase, and whether it is done."""

    mode: str
    phase_index: int
    status: RunStatus = RunStatus.RUNNING
    detail: str = ""
    extra: dict[str, float] = field(default_factory=dict)

    @property
    def done(self) -> bool:
        return self.status is not RunStatus.RUNNING


class Autopilot(Protocol):
    """An autopilot backend. One instance flies one run."""

    name: str

    def reset(self, ctx: AutopilotContext) -> None:
        """Prepare to fly ``ctx.mission`` (connect, upload, arm as needed). Raises AutopilotError."""
        ...

    def step(self, obs: Observation) -> ActuatorCommand:
        """Commands for the next physics step, given this step's observation."""
        ...

    def status(self) -> AutopilotStatus:
        """Current mode/phase and whether the mission is finished (and how)."""
        ...

    def drain_events(self) -> list[Event]:
        """Events since the last call (mode changes, geofence, touchdown...)."""
        ...

    def close(self) -> None:
        """Release sockets/threads. Idempotent."""
        ...
