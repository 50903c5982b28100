"""Mission specification (``pipelines/missions/*.yaml``): phases the autopilot flies and
checks evaluated on the recorded run.

Positions are metres in the world ENU frame of the built world; altitudes ``*_agl_m`` are
above the terrain at the home position (PX4 "relative altitude"). Times in seconds.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Annotated, Literal

from pydantic import Field, model_validator

from vinecli.names import SafeName
from vinecli.specs import StrictModel
from vinecli.specs.limits import (
    MAX_DISTANCE_M,
    MAX_DURATION_S,
    MAX_FENCE_VERTICES,
    MAX_HEIGHT_M,
    MAX_RATE_HZ,
    MAX_SPEED_MPS,
    Speed,
    Vec2Coord,
    Vec3Coord,
    Vec3Speed,
    WaypointEnu,
    over_limit,
)
from vinecli.specs.wind import WindSpec
from vinecli.spray_defaults import SPRAY_DEFAULTS

Vec2L = Vec2Coord
Vec3L = Vec3Coord


class TakeoffPhase(StrictModel):
    type: Literal["takeoff"] = "takeoff"
    altitude_agl_m: float = Field(gt=0, le=MAX_HEIGHT_M, description="target height above home, m")
    climb_speed_mps: float | None = Field(None, gt=0, le=MAX_SPEED_MPS, description="default: vehicle max_vel_up")
    tolerance_m: float = Field(0.3, gt=0, le=MAX_DISTANCE_M, description="phase ends when within this of the target")
    timeout_s: float = Field(30.0, gt=0, le=MAX_DURATION_S,
                             description="s the take-off may take beyond the climb itself (altitude / climb speed)")


class HoldPhase(StrictModel):
    type: Literal["hold"] = "hold"
    duration_s: float = Field(gt=0, le=MAX_DURATION_S)


class GotoPhase(StrictModel):
    type: Literal["goto"] = "goto"
    position_enu: Vec2L = Field(description="target x east, y north, m")
    altitude_agl_m: float | None = Field(None, ge=-MAX_HEIGHT_M, le=MAX_HEIGHT_M, description="default: keep the current altitude")
    speed_mps: float | None = Field(None, gt=0, le=MAX_SPEED_MPS)
    acceptance_radius_m: float = Field(0.5, gt=0, le=MAX_DISTANCE_M)
    yaw_deg: float | None = Field(None, description="ENU yaw, deg from east CCW; default: keep")
    timeout_s: float = Field(120.0, gt=0, le=MAX_DURATION_S)


class WaypointsPhase(StrictModel):
    """Fly through waypoints (ENU x, y, altitude AGL) at a speed; optional sprayer flow."""

    type: Literal["waypoints"] = "waypoints"
    waypoints: list[WaypointEnu] = Field(min_length=1, description="(x east m, y north m, altitude AGL m)")
    speed_mps: float = Field(2.0, gt=0, le=MAX_SPEED_MPS)
    acceptance_radius_m: float = Field(0.5, gt=0, le=MAX_DISTANCE_M)
    flow_lps: float | None = Field(None, ge=0, description="sprayer flow during the phase, L/s (None = unchanged)")
    timeout_s: float = Field(600.0, gt=0, le=MAX_DURATION_S)


class RefillSpec(StrictModel):
    """Sorties of a spray job: when the tank (or the battery) runs low the vehicle records the
    breakpoint, returns home, lands, is refilled (and gets a fresh battery when the next sortie needs
    one), takes off and resumes the rows at the breakpoint (flying in from behind it at spraying speed).
    Ground times, the battery reserve and the swap rule default to the vehicle's ``sprayer.operations``."""

    time_s: float | None = Field(None, ge=0, le=3600, description="fixed ground time of a stop, s; default: the "
                                 "vehicle's operations model (handling + refill at its pump rate, battery swap)")
    fill_l: float | None = Field(None, gt=0, description="litres after a refill; default: the tank's capacity")
    reserve_l: float = Field(0.0, ge=0, description="return for a refill when the tank holds this much or less, L")
    swap_battery: bool | Literal["auto"] = Field("auto", description="'auto': a fresh battery when the next sortie "
                                                 "could not land with the reserve; true: at every stop; false: never")
    reserve_soc: float | None = Field(None, ge=0, lt=1, description="state of charge a sortie must land with; "
                                      "default: the vehicle's sprayer.operations.reserve_soc, else its battery low_soc")
    return_altitude_agl_m: float = Field(5.0, gt=0, le=120, description="transit height above home, m")
    overlap_m: float = Field(0.0, ge=0, le=10, description="open the sprayer this far before the breakpoint when "
                             "resuming, m (0: at the breakpoint, the deposits of the two sorties then join evenly)")
    max_sorties: int = Field(30, ge=1, le=1000)


class PrescriptionSpec(StrictModel):
    """A grower's prescription map (docs/dose.md): zones (GeoJSON, Shapefile, GeoPackage) with a rate ``column``,
    a rate GeoTIFF, or ISO 11783-10 TaskData (``TASKDATA.XML`` or its folder); ``path`` relative to the mission."""

    path: str = Field(min_length=1, description="the map file (or TaskData folder)")
    column: str | None = Field(None, description="zones: the rate column")
    layer: str | None = Field(None, description="zones: the layer (default: the first)")
    default_lpha: float | None = Field(None, ge=0, le=10_000.0, description="rate where the map prescribes nothing, L/ha")
    units: str = Field("L/ha", description="units of the map's rates: L/ha, gal/ac or mL/m2")


class SprayPhase(StrictModel):
    """Boustrophedon passes along the world's vine rows at a height above the canopy, flow on
    along each row and off in the turns. With ``refill`` a ``rows_done`` job continues across
    tanks (sorties)."""

    type: Literal["spray"] = "spray"
    rows: Literal["world"] | list[int] | list[list[Vec2L]] = Field(
        "world", description="'world' = all rows of the world, indices into them, or explicit polylines (ENU)"
    )
    height_agl_m: float = Field(SPRAY_DEFAULTS.height_m, gt=0, le=MAX_HEIGHT_M,
                                description="height above the terrain under the drone, m")
    speed_mps: float = Field(SPRAY_DEFAULTS.speed_mps, gt=0, le=MAX_SPEED_MPS)
    flow_lps: float | None = Field(None, gt=0, description="nozzle flow while over a row, L/s (or give rate_lpha)")
    rate_lpha: float | None = Field(
        None, gt=0, le=10_000.0,
        description="application rate, L/ha: flow = rate x track width x speed / 10 000 (the track width of the plan's "
                    "passes, from the vehicle's effective swath at the phase's height and speed)",
    )
    lwa_dose_l: float | None = Field(None, gt=0, le=10_000.0, description="dose: litres of spray per 10,000 m² of "
                                     "leaf wall area (EPPO PP 1/239), converted per canopy segment (docs/dose.md)")
    trv_dose_l: float | None = Field(None, gt=0, le=100_000.0, description="dose: litres of spray per 10,000 m³ of "
                                     "tree-row volume, converted per canopy segment")
    sides: Literal[1, 2] = Field(2, description="sides of each row treated (leaf wall area)")
    prescription: PrescriptionSpec | None = Field(None, description="dose: a prescription map (rates per zone or cell)")
    segment_m: float | None = Field(None, ge=0.5, le=20.0, description="dose resolution along the rows, m: the world's "
                                    "canopy segments merged to about this length (default: the world's segments)")
    until: Literal["rows_done", "empty"] = Field("rows_done", description="'empty' repeats passes until the tank is empty")
    allow_slower: bool = Field(False, description="fly slower than speed_mps when the sprayer cannot deliver the rate "
                                                  "at that speed (else the run is refused)")
    canopy_width_m: float | None = Field(None, gt=0, le=10.0, description="width of the canopy band each row is dosed "
                                         "on, m (passes are laid out for it); default: the world's canopy_width_m")
    timeout_s: float = Field(900.0, gt=0, le=MAX_DURATION_S)
    refill: RefillSpec | None = Field(None, description="refill sorties until every row is sprayed (until: rows_done)")
    plan_wind_enu: tuple[Speed, Speed] | None = Field(
        None, description="wind the passes are planned for, m/s ENU: they are displaced upwind by the plume's drift "
                          "across the rows (swath displacement); default: the mission's mean wind, set at the run's set-up")

    @model_validator(mode="after")
    def _refill_needs_rows_done(self) -> SprayPhase:
        if self.refill is not None and self.until != "rows_done":
            raise ValueError("refill sorties need until: rows_done (until: empty ends at the first empty tank)")
        return self

    @model_validator(mode="after")
    def _flow_or_rate(self) -> SprayPhase:
        given = [v is not None for v in (self.flow_lps, self.rate_lpha, self.lwa_dose_l, self.trv_dose_l,
                                         self.prescription)]
        if sum(given) != 1:
            raise ValueError("give exactly one of flow_lps, rate_lpha, lwa_dose_l, trv_dose_l or prescription")
        return self

    @property
    def segment_dose(self) -> bool:
        """The dose is per canopy segment or map cell (:mod:`vinecli.sim.dose_setup` resolves it at set-up)."""
        return self.lwa_dose_l is not None or self.trv_dose_l is not None or self.prescription is not None


class SprayerPhase(StrictModel):
    """Switch the sprayer (DO_SET_ACTUATOR): flow in L/s, 0 = off. Instantaneous."""

    type: Literal["sprayer"] = "sprayer"
    flow_lps: float = Field(ge=0)


class LandPhase(StrictModel):
    type: Literal["land"] = "land"
    descent_speed_mps: float = Field(0.7, gt=0, le=MAX_SPEED_MPS)
    timeout_s: float = Field(60.0, gt=0, le=MAX_DURATION_S,
                             description="s the land may take beyond the descent itself (its height / descent_speed_mps)")


class RtlPhase(StrictModel):
    type: Literal["rtl"] = "rtl"
    return_altitude_agl_m: float = Field(5.0, gt=0, le=MAX_HEIGHT_M)
    timeout_s: float = Field(180.0, gt=0, le=MAX_DURATION_S,
                             description="s the return may take beyond its nominal climb, flight home and descent")


class InitialState(StrictModel):
    """State an open-loop test starts from (default: at rest on the ground at the spawn pose)."""

    position_enu: WaypointEnu | None = Field(None, description="m; z is height above terrain")
    velocity_enu: Vec3Speed = (0.0, 0.0, 0.0)
    rpy_deg: Vec3L = (0.0, 0.0, 0.0)
    angular_velocity_flu: Vec3L = (0.0, 0.0, 0.0)


class OpenLoopPhase(StrictModel):
    """Autopilot off: rotor speeds held or scheduled (step tests, system identification).

    ``rotor_speeds_rad_s`` is one speed for all rotors or one per rotor; ``schedule`` is a list of
    ``[t_s, speeds]`` breakpoints relative to the phase start (held piecewise constant).
    """

    type: Literal["open_loop"] = "open_loop"
    duration_s: float = Field(gt=0, le=MAX_DURATION_S)
    rotor_speeds_rad_s: float | list[float] | None = None
    schedule: list[tuple[float, float | list[float]]] | None = None
    flow_lps: float = Field(0.0, ge=0)
    initial_state: InitialState | None = None

    @model_validator(mode="after")
    def _one_source(self) -> OpenLoopPhase:
        if (self.rotor_speeds_rad_s is None) == (self.schedule is None):
            raise ValueError("give exactly one of rotor_speeds_rad_s or schedule")
        return self


Phase = Annotated[
    TakeoffPhase | HoldPhase | GotoPhase | WaypointsPhase | SprayPhase | SprayerPhase | LandPhase | RtlPhase | OpenLoopPhase,
    Field(discriminator="type"),
]


class GeofenceSpec(StrictModel):
    """Polygon (ENU, m) + max altitude + cylinder around home; action as PX4's GF_ACTION."""

    polygon_enu: list[Vec2L] | None = Field(None, description="inclusion polygon vertices, m")
    max_altitude_agl_m: float | None = Field(None, gt=0, le=MAX_HEIGHT_M)
    max_horizontal_distance_m: float | None = Field(None, gt=0, le=MAX_DISTANCE_M, description="GF_MAX_HOR_DIST from home")
    action: Literal["none", "warn", "hold", "rtl", "land", "terminate"] = "hold"

    @model_validator(mode="after")
    def _polygon(self) -> GeofenceSpec:
        if self.polygon_enu is not None and len(self.polygon_enu) < 3:
            raise ValueError("polygon_enu needs at least 3 vertices")
        problem = over_limit("fence vertices", len(self.polygon_enu or ()), MAX_FENCE_VERTICES, "simplify the fence")
        if problem:
            raise ValueError(problem)
        return self


class CheckSpec(StrictModel):
    """A check evaluated after the run: reduce(quantity over window) op bound.

    ``window`` ends may be numbers (s from start), or event-relative strings such as
    ``"liftoff-1.0"``, ``"liftoff+3"``, ``"end-5"``, ``"phase:2"`` (start of phase 2),
    ``"phase_end:2"``.
    """

    name: str
    quantity: str = Field(description="time-series column or derived metric ('metric:<name>'), or 'status'")
    reduce: Literal["max", "min", "mean", "final", "at", "std", "absmax", "range"] = "final"
    window: tuple[float | str, float | str] | None = None
    at: float | str | None = Field(None, description="time for reduce 'at'")
    op: Literal["<", "<=", ">", ">=", "==", "!=", "between", "within_pct"] = "<="
    bound: float | str | tuple[float, float] = Field(description="number, [lo, hi] for between, or a status string")
    reference: float | str | None = Field(None, description="for within_pct: the expected value or a metric name")
    description: str = ""


class DoseSpec(StrictModel):
    """Bands of the dose checks every mission with a spray phase gets (``dose_*`` checks, judged on the deposit
    along each row's planned stretch); a mission overrides a band here, or a check by giving one of the same name."""

    check: bool = Field(True, description="add the dose checks (false: the mission judges the dose itself, or not)")
    rate_tolerance: float = Field(0.15, gt=0, le=10, description="each row's mean rate within this share of the asked rate")
    hot_ratio: float = Field(1.3, gt=1, le=100, description="no window along a row above this x the asked rate")
    gap_ratio: float = Field(0.6, ge=0, lt=1, description="no window along a row's planned stretch below this x the asked rate")
    window_m: float = Field(1.0, gt=0, le=100, description="length of the windows along the rows, m")
    coverage_min: float = Field(0.98, ge=0, le=1, description="share of the planned stretches with >= 50 % of the asked rate")
    drift_max: float = Field(0.05, ge=0, le=1, description="share of the liquid landing outside the geofence (or the field)")
    no_spray_max: float = Field(0.001, ge=0, le=1, description="share of the liquid landing in the world's no-spray zones")


class MissionSpec(StrictModel):
    """A test mission."""

    name: SafeName
    description: str = ""
    vehicle: str | None = Field(None, description="vehicle name (vehicles/<name>.yaml) or path; default: the world's")
    autopilot: Literal["builtin", "px4", "ardupilot"] = "builtin"
    truth: bool = Field(False, description="controllers use ground truth instead of the estimator")
    tank_fill_l: float | None = Field(None, ge=0, description="default: full")
    payload_kg: float | None = Field(None, ge=0, description="replaces the vehicle's payload mass")
    wind: WindSpec | None = Field(None, description="replaces the world's wind law")
    geofence: GeofenceSpec | None = Field(None, description="replaces the world's geofence")
    max_duration_s: float = Field(120.0, gt=0, le=MAX_DURATION_S)
    record_rate_hz: float = Field(50.0, gt=0, le=MAX_RATE_HZ)
    phases: list[Phase] = Field(min_length=1)
    checks: list[CheckSpec] = Field(default_factory=list)
    dose: DoseSpec = Field(default_factory=DoseSpec, description="bands of the default dose checks of spray missions")

    @model_validator(mode="after")
    def _initial_state_first(self) -> MissionSpec:
        """``initial_state`` sets where the run starts, so only the first phase may carry it."""
        for i, ph in enumerate(self.phases[1:], start=2):
            if isinstance(ph, OpenLoopPhase) and ph.initial_state is not None:
                raise ValueError(f"phase {i} (open_loop): initial_state is only allowed on the first phase "
                                 "(it sets the state the run starts from)")
        return self


def phase_rows(phase: SprayPhase, world_rows: Sequence[Sequence[tuple[float, float]]]) -> list[list[tuple[float, float]]]:
    """The rows a spray phase targets: the world's, some of them by index, or its own polylines (ENU m)."""
    if phase.rows == "world":
        return [[tuple(q) for q in r] for r in world_rows]  # type: ignore[misc]
    if phase.rows and isinstance(phase.rows[0], int):
        return [[tuple(q) for q in world_rows[i]] for i in phase.rows if 0 <= i < len(world_rows)]  # type: ignore[misc, index]
    return [[tuple(q) for q in r] for r in phase.rows]  # type: ignore[misc, union-attr]
