"""THE run set-up: a world, a mission and a vehicle resolved once into a :class:`PreparedRun`.

:func:`prepare_run` is the one place where a run's inputs are put together before the engine
starts; :func:`vinecli.sim.runner.simulate` flies what it returns, and both
:func:`vinecli.sim.runner.run_simulation` (the library entry) and
:func:`vinecli.runs.mission.run_mission` (``vinecli run mission``) go through it:

* mission overrides of the command line (:class:`RunOverrides`: autopilot, truth, recording rate);
* the vehicle: the ``vehicle`` argument (a caller that loaded the mission's already) > the mission's
  ``vehicle`` name > the world's; the mission's ``payload_kg`` applied; its URDF (the world's, or
  written once to a temporary directory that the prepared run owns);
* the rows: the world's, or, for a ``rows: auto`` world built before rows were detected at build
  time, detected once on its height grid (:func:`resolve_rows`; a copy, the loaded World is unchanged);
* spray phases given in L/ha turned into their nozzle flow (what the autopilot flies);
* tank fill, wind, geofence (mission > world), the physics clock;
* the spawn (:class:`Spawn`): where the CoM starts (world spawn, rest position of another vehicle or
  a first open-loop phase's ``initial_state``), attitude, velocities and, for an airborne start,
  home on the terrain below -- each rest position computed once.

What needs the engine (placing the skids on the collision surface, settling at rest) is done by
:func:`~vinecli.sim.runner.simulate`. Positions ENU m, attitudes quaternions (x, y, z, w) body FLU
-> world ENU, angular velocities body FLU rad/s.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vinecli.errors import SpecError
from vinecli.frames import QuatXYZW, Vec3, quat_from_euler
from vinecli.specs.mission import GeofenceSpec, MissionSpec, OpenLoopPhase
from vinecli.specs.vehicle import VehicleSpec
from vinecli.specs.wind import WindSpec
from vinecli.world.model import World, rest_position

if TYPE_CHECKING:
    from vinecli.spray.deposition import DepositionConfig

__all__ = ["PreparedRun", "RunOverrides", "Spawn", "prepare_run", "resolve_rows"]

log = logging.getLogger(__name__)

#: ENU polylines (x, y), m
RowsEnu = tuple[tuple[tuple[float, float], ...], ...]


@dataclass(frozen=True)
class RunOverrides:
    """Overrides of a mission's fields from the command line (None: the mission's own)."""

    autopilot: str | None = None
    truth: bool | None = None
    record_rate_hz: float | None = None  # Hz, > 0

    def apply(self, mission: MissionSpec, source: Path | str | None = None) -> MissionSpec:
        """``mission`` with the overrides, validated again; SpecError (naming ``source``) for a rate <= 0."""
        updates: dict[str, Any] = {}
        if self.autopilot is not None:
            updates["autopilot"] = self.autopilot
        if self.truth is not None:
            updates["truth"] = self.truth
        if self.record_rate_hz is not None:
            if not self.record_rate_hz > 0:
                raise SpecError(f"record rate must be > 0 Hz, got {self.record_rate_hz}", path=source)
            updates["record_rate_hz"] = float(self.record_rate_hz)
        if not updates:
            return mission
        return MissionSpec.model_validate({**mission.model_dump(), **updates})


@dataclass(frozen=True)
class Spawn:
    """How the vehicle starts, before the engine places it on the collision surface and settles it."""

    position_enu: Vec3  # CoM, m ENU (on the ground: placed on the collision surface by the engine)
    quat_xyzw: QuatXYZW  # attitude, body FLU -> world ENU
    velocity_enu: Vec3  # m/s
    omega_flu: Vec3  # body rates, rad/s FLU
    airborne: bool  # a first open-loop phase's initial_state above the terrain: starts in the air
    #: airborne start: home = the CoM at rest on the terrain below, m ENU (on the ground: the settled pose)
    home_enu: Vec3 | None = None
    #: airborne start: the open-loop phase whose first rotor commands the motors start at
    spin_up: OpenLoopPhase | None = None

    @property
    def at_rest(self) -> bool:
        """On the ground, not moving: settled at rest before t = 0."""
        return (not self.airborne and self.velocity_enu == (0.0, 0.0, 0.0)
                and self.omega_flu == (0.0, 0.0, 0.0))


@dataclass(frozen=True)
class PreparedRun:
    """Everything one run needs, resolved once (:func:`prepare_run`); the loop reads it, never changes it.

    Independent of the seed: the same prepared run flies any seed. Owns the temporary URDF of a vehicle
    other than the world's: use it as a context manager (or call :meth:`close`).
    """

    world: World  # the world flown, its rows resolved (``vine_rows_enu``)
    mission: MissionSpec  # overrides applied: what the run directory records and the checks read
    flight: MissionSpec  # ``mission`` with spray rates (L/ha) turned into flows (L/s): what the autopilot flies
    vehicle: VehicleSpec  # payload override applied
    urdf: Path  # the vehicle's URDF (the world's, or a temporary file this run owns)
    rows: RowsEnu  # the world's vine rows, ENU m (= ``world.vine_rows_enu``)
    physics_rate_hz: float  # Hz
    dt_us: int  # physics step, µs (round(1e6 / rate))
    gravity: float  # m/s², positive
    rigid_mass_kg: float  # vehicle without liquid, kg
    tank_fill_l: float  # liquid at t = 0, L (0 without a tank)
    wind: WindSpec  # mission > world
    geofence: GeofenceSpec | None  # mission > world
    spawn: Spawn
    end_on_crash: bool = True  # a hard impact ends the run (CRASHED)
    crash_speed_mps: float = 3.0  # vertical speed at first contact above which an impact is a crash, m/s
    deposition: bool = True  # run the spray transport model (only with a tank)
    deposition_config: DepositionConfig | None = None  # its options (None: defaults)
    segment_rates: dict[int, Any] = field(default_factory=dict)  # phase index -> SegmentRates (docs/dose.md)
    _urdf_dir: tempfile.TemporaryDirectory[str] | None = field(default=None, repr=False, compare=False)

    def close(self) -> None:
        """Remove the temporary URDF (if any)."""
        if self._urdf_dir is not None:
            self._urdf_dir.cleanup()

    def __enter__(self) -> PreparedRun:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def resolve_rows(world: World) -> World:
    """``world`` with its vine rows: a ``rows: auto`` world built before rows were detected at build time
    (no stored rows) gets them detected on its height grid with THE detector, in a copy; otherwise ``world``."""
    if not world.rows_auto or world.vine_rows_enu or world.terrain.grid is None:
        return world
    from vinecli.rows.source import detect_rows_on_grid

    det = detect_rows_on_grid(world.terrain.grid)
    log.info("world %s: %s", world.name, det.summary())
    return dataclasses.replace(world, vine_rows_enu=det.rows)


def prepare_run(
    world: World,
    mission: MissionSpec,
    *,
    vehicle: VehicleSpec | None = None,
    overrides: RunOverrides | None = None,
    source: Path | str | None = None,
    end_on_crash: bool = True,
    crash_speed_mps: float = 3.0,
    deposition: bool | DepositionConfig = True,
) -> PreparedRun:
    """Resolve one run (see the module doc); close the result (or use ``with``) to drop its temporary URDF.

    Parameters
    ----------
    world : the built world (:func:`vinecli.world.load_world`).
    mission : the mission spec (overrides of the mission itself -- vehicle, payload_kg, tank_fill_l, wind,
        geofence, a first open-loop phase's initial_state -- are applied here).
    vehicle : the vehicle to fly, already loaded (e.g. :func:`vinecli.missions.spec_io.read_mission`); None:
        the mission's ``vehicle`` name (loaded here), else the world's.
    overrides : command-line overrides (autopilot, truth, recording rate).
    source : the mission file or name, for error messages.
    end_on_crash, crash_speed_mps : a hard impact (vertical speed at first contact above crash_speed_mps, m/s)
        ends the run (else only the ``crash`` event is logged).
    deposition : run the spray transport model (vehicles with a tank); a DepositionConfig sets its options.

    Raises SpecError for a tank fill the vehicle cannot take or a recording rate <= 0.
    """
    if overrides is not None:
        mission = overrides.apply(mission, source)
    world = resolve_rows(world)
    veh = _vehicle(world, mission, vehicle)
    from vinecli.rows.spray_rate import resolve_spray_rates
    from vinecli.sim.dose_setup import resolve_dose_phases

    dosed, segment_rates = resolve_dose_phases(mission, world)  # per-segment doses: their rates (docs/dose.md)
    fence = mission.geofence if mission.geofence is not None else world.geofence
    flight = resolve_spray_rates(  # phases in L/ha fly the equivalent flow of their plan, within the pump's range
        dosed, veh, world.vine_rows_enu, fence_enu=fence.polygon_enu if fence is not None else None,
        terrain_bounds=tuple(world.terrain.bounds), air_density=float(world.air_density),
        canopy_width_m=world.canopy_width_m, no_spray=world.no_spray_enu,
        wind_xy=(mission.wind if mission.wind is not None else world.wind).mean_horizontal_enu())
    rate = float(world.physics_rate_hz)
    tank_spec = veh.tank
    if tank_spec is None:
        if mission.tank_fill_l:
            raise SpecError(f"mission fills a tank but vehicle {veh.name!r} has none")
        fill = 0.0
    else:
        fill = tank_spec.capacity_l if mission.tank_fill_l is None else float(mission.tank_fill_l)
        if fill > tank_spec.capacity_l + 1e-9:
            raise SpecError(f"tank_fill_l {fill} exceeds the tank capacity {tank_spec.capacity_l} L of {veh.name!r}")
    own_vehicle = veh == world.vehicle
    spawn = _spawn(world, flight, veh, own_vehicle)
    urdf = world.urdf
    urdf_dir: tempfile.TemporaryDirectory[str] | None = None
    if not own_vehicle:
        from vinecli.vehicle.urdf import write_urdf

        urdf_dir = tempfile.TemporaryDirectory(prefix="vinecli-urdf-")
        urdf = write_urdf(veh, Path(urdf_dir.name) / f"{veh.name}.urdf")
    return PreparedRun(
        segment_rates=segment_rates,
        world=world,
        mission=mission,
        flight=flight,
        vehicle=veh,
        urdf=urdf,
        rows=tuple(tuple((float(p[0]), float(p[1])) for p in row) for row in world.vine_rows_enu),
        physics_rate_hz=rate,
        dt_us=int(round(1e6 / rate)),
        gravity=float(world.gravity),
        rigid_mass_kg=veh.dry_mass(),
        tank_fill_l=fill,
        wind=mission.wind if mission.wind is not None else world.wind,
        geofence=fence,
        spawn=spawn,
        end_on_crash=end_on_crash,
        crash_speed_mps=crash_speed_mps,
        deposition=bool(deposition) and tank_spec is not None,
        deposition_config=None if isinstance(deposition, bool) else deposition,
        _urdf_dir=urdf_dir,
    )


def _vehicle(world: World, mission: MissionSpec, vehicle: VehicleSpec | None) -> VehicleSpec:
    """The vehicle a run flies: ``vehicle`` > ``mission.vehicle`` (loaded by name) > the world's; payload override."""
    if vehicle is None:
        if mission.vehicle:
            from vinecli.vehicle import load_vehicle

            vehicle = load_vehicle(mission.vehicle)
        else:
            vehicle = world.vehicle
    if mission.payload_kg is not None:
        vehicle = vehicle.model_copy(update={"payload": vehicle.payload.model_copy(update={"mass_kg": mission.payload_kg})})
    return vehicle


def _spawn(world: World, mission: MissionSpec, veh: VehicleSpec, own_vehicle: bool) -> Spawn:
    """The start: the world's spawn (its vehicle) or this vehicle's rest position there, level at the spawn
    yaw; or the first open-loop phase's ``initial_state`` (x, y, height above the rest position, rpy in deg)."""
    first = mission.phases[0]
    init = first.initial_state if isinstance(first, OpenLoopPhase) else None
    if init is None or init.position_enu is None:
        sx, sy = world.spawn_enu[0], world.spawn_enu[1]
        pos = world.spawn_enu if own_vehicle else rest_position(world.terrain, veh, sx, sy)
    if init is None:
        return Spawn(pos, quat_from_euler(0.0, 0.0, world.spawn_yaw_rad), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), False)
    airborne = False
    home: Vec3 | None = None
    if init.position_enu is not None:
        x, y, hz = init.position_enu
        rest = rest_position(world.terrain, veh, x, y)
        pos = (x, y, rest[2] + hz)
        airborne = hz > 0.0
        home = rest if airborne else None
    r, p_, yw = (math.radians(a) for a in init.rpy_deg)
    vel: Vec3 = tuple(float(v) for v in init.velocity_enu)  # type: ignore[assignment]
    omega: Vec3 = tuple(float(w) for w in init.angular_velocity_flu)  # type: ignore[assignment]
    spin_up = first if airborne and isinstance(first, OpenLoopPhase) else None
    return Spawn(pos, quat_from_euler(r, p_, yw), vel, omega, airborne, home, spin_up)
