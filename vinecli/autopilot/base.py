"""The interface every autopilot backend implements (built-in cascade, PX4 SITL, plugins).

Backends never touch PyBullet: they receive an :class:`~vinecli.types.Observation`
per physics step and return an :class:`~vinecli.types.ActuatorCommand`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, Final, Protocol

from vinecli.autopilot.estimate import StateEstimate
from vinecli.autopilot.terrain import TerrainDatabase
from vinecli.frames import Vec3
from vinecli.geo import GeoOrigin
from vinecli.specs.mission import GeofenceSpec, MissionSpec
from vinecli.specs.vehicle import VehicleSpec
from vinecli.types import ActuatorCommand, Event, Observation

if TYPE_CHECKING:
    from vinecli.rows.segment_rates import SegmentRates


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
    """Everything a backend is given at reset: the mission, the airframe, the map, where home is.
    Nothing of the simulation's state: a backend senses the vehicle through the observations."""

    mission: MissionSpec
    vehicle: VehicleSpec  # the airframe as configured (its payload included; not the liquid in the tank)
    origin: GeoOrigin
    home_enu: Vec3  # m, the spawn point on the terrain (vehicle base position at rest)
    physics_dt_us: int  # physics step, µs
    vine_rows_enu: tuple[tuple[tuple[float, float], ...], ...] = ()  # world's rows, polylines (x, y) m
    geofence: GeofenceSpec | None = None
    #: the world's terrain map (DEM) as a planner loads it; None: flat at the home ground
    terrain: TerrainDatabase | None = None
    seed: int = 0
    #: mapped terrain extent (xmin, ymin, xmax, ymax) ENU m; None = unbounded
    terrain_bounds: tuple[float, float, float, float] | None = None
    #: () -> bool: the run is being stopped (a signal, a wall-clock limit); a backend polls it in long waits
    #: (a firmware's boot) and returns, the loop then ends the run as interrupted
    should_stop: Callable[[], bool] | None = None
    #: an external state estimate to fly on instead of the backend's own estimator: the simulator's
    #: perfect one in ground-truth runs (``truth: true``); None: the backend estimates from its sensors
    estimator: StateEstimate | None = None
    #: air density of the world, kg/m³ (the spray plan's pattern depends on it through the downwash)
    air_density_kgm3: float = 1.225
    #: the world's no-spray zones (rings grown by their buffer, x y m): the spray plan closes the sections at them
    no_spray_enu: tuple[tuple[tuple[float, float], ...], ...] = ()
    #: spray phases dosed per row segment (a canopy dose or a prescription map): phase index -> their
    #: :class:`~vinecli.rows.segment_rates.SegmentRates` (docs/dose.md); a backend flies them as its firmware can
    segment_rates: dict[int, SegmentRates] = field(default_factory=dict)

    def terrain_height(self, x: float, y: float) -> float:
        """Terrain z (ENU m) of the map at (x, y); flat at the home ground without a map."""
        t = self.terrain
        return t.height(x, y) if t is not None else self.home_enu[2] - self.vehicle.frame.landing_gear_height_m


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
