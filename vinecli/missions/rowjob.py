"""``vinecli plan rows``: rows of a DSM or a built world -> spray plan files (library side of the command).

Writes ``OUT`` (the whole field as one QGroundControl ``.plan``: take-off, the operator plan of
:func:`~vinecli.rows.plan.plan_rows`, land), ``OUT-stem.rows.geojson`` beside it (RFC 7946: one LineString
per row in WGS84 longitude/latitude, through the source's CRS; properties ``index``, ``length_m``), and
when the rows need more than one tank ``OUT-stem.sortie-N.plan`` (take-off, that sortie's rows, RTL).

Sources: a DSM GeoTIFF (rows detected on it; frame: local metres along the CRS axes about the raster
centre; the plan keeps its headland turns on the raster's data extent) or a world directory (its rows:
the rows ``world build`` detected or the world file lists, i.e. the rows the runs fly; ``detect`` re-runs
the detector on the world's height grid; fence: the world's geofence, else its terrain bounds).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from vinecli.errors import InputError, OutputError, check_range
from vinecli.gis.georef import Georef
from vinecli.gis.write import rows_features, write_features
from vinecli.inputs import note_input, reading_inputs
from vinecli.missions.rowjob_dose import (
    CanopySource,
    DoseOptions,
    mission_dose,
    plan_segment_rates,
    rates_paths,
    write_rates,
)
from vinecli.outputs import check_output_file
from vinecli.rows.detect import Polyline, RowDetection
from vinecli.rows.plan import RowPlan, plan_accel, plan_rows, split_sorties
from vinecli.rows.segment_rates import SegmentRates
from vinecli.rows.source import RowFrame
from vinecli.specs.vehicle import DEFAULT_VEHICLE, VehicleSpec
from vinecli.spray_defaults import SPRAY_DEFAULTS

if TYPE_CHECKING:
    from vinecli.specs.mission import MissionSpec

__all__ = ["RowsJob", "plan_rows_job"]


@dataclass
class RowsJob:
    """What ``plan rows`` found and wrote."""

    rows: list[Polyline]
    detection: RowDetection | None
    plan: RowPlan
    sorties: int
    files: list[Path] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    rates: SegmentRates | None = None


def _bbox_polygon(x: np.ndarray, y: np.ndarray, valid: np.ndarray) -> list[tuple[float, float]]:
    """Rectangle (ENU m) around the cells with data."""
    jj, ii = np.nonzero(valid)
    x0, x1 = float(x[ii.min()]), float(x[ii.max()])
    y0, y1 = float(y[jj.min()]), float(y[jj.max()])
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


@dataclass(frozen=True)
class RowsPlanOptions:
    """The options of ``vinecli plan rows`` (:func:`plan_rows_job`); the defaults are the command's."""

    spacing: float | None = None  # expected row spacing, m (None: searched over 0.5-6 m)
    height: float = SPRAY_DEFAULTS.height_m  # spray height above the canopy surface, m
    speed: float = SPRAY_DEFAULTS.speed_mps  # ground speed along the rows, m/s
    flow: float = SPRAY_DEFAULTS.flow_lps  # nozzle flow on the rows, L/s
    takeoff: float = SPRAY_DEFAULTS.takeoff_m  # take-off altitude above home, m
    detect: bool = False  # a world source: detect rows on its height grid instead of taking its rows
    world_rows: bool = False  # a world source: its rows (an error when it has none)
    vehicle: str | None = None  # None: the world's, else the default sprayer
    tank_l: float | None = None  # litres per sortie (None: the vehicle's tank; 0: one sortie)
    fence_margin: float | None = None  # m inside the fence (None: 1 m inside a world's, 0 inside a DSM's extent)
    home: tuple[float, float] | None = None  # take-off point, ENU m of the source (None: spawn / a corner row end)


def plan_rows_job(source: Path, out: Path, options: RowsPlanOptions = RowsPlanOptions(), *,
                  mission_out: Path | None = None, overwrite: bool = False,
                  dose: DoseOptions | None = None) -> RowsJob:
    """Detect or load rows, plan them and write the plan files (see the module docstring). ``fence_margin``
    (m, :class:`RowsPlanOptions`): default 1 m inside a world's geofence, 0 m inside a DSM's data extent (the
    survey area: its edge rows are flown, only the headland turns are kept over the surveyed ground). Every file
    is checked before the first is written: none may be an input, or replace an existing file without
    ``overwrite`` (OutputError, exit 2, nothing written). ``dose``: also the rate of every row segment
    (:mod:`vinecli.missions.rowjob_dose`), its map checked before anything is written."""
    dose = dose if dose is not None and dose.given else None
    with reading_inputs():
        note_input(source, "world" if source.is_dir() else "DSM")
        if dose is not None:
            dose.check()
        _check_targets([out, _geojson_path(out), *(rates_paths(out) if dose is not None else []),
                        *([mission_out] if mission_out is not None else [])], overwrite)
        return _plan_rows_job(source, out, options, (mission_out, overwrite), dose)


def _check_targets(targets: list[Path], overwrite: bool) -> None:
    """Refuse (OutputError, exit 2) before anything is written: two outputs at one path (``--mission`` naming the
    plan or its rows file), or any output that must not be written (:func:`check_output_file`)."""
    seen: dict[Path, Path] = {}
    for t in targets:
        key = Path(os.path.abspath(t))
        if key in seen:
            raise OutputError(f"two outputs would be written at one path ({seen[key]} and {t})", path=t)
        seen[key] = t
        check_output_file(t, overwrite=overwrite)


def _check_options(veh: VehicleSpec, *, speed: float, height: float, flow: float, takeoff: float,
                   tank_l: float | None) -> None:
    """Each option finite and in its range for ``veh`` (exit 2 naming the option): a speed above the vehicle's top
    speed would be planned for turns and times never flown (and 1e308 m/s made the run-in infinite)."""
    check_range("--speed", speed, 0.0, veh.control.max_vel_xy, open_lo=True, why="the vehicle's control.max_vel_xy")
    check_range("--height", height, 0.0, 1000.0, open_lo=True)
    check_range("--flow", flow, 0.0, 100.0)
    check_range("--takeoff", takeoff, 0.0, 1000.0, open_lo=True)
    if tank_l is not None:
        check_range("--tank", tank_l, 0.0, 1e4)


def _geojson_path(out: Path) -> Path:
    """The rows' GeoJSON written beside the plan ``out``, named after it (never a fixed name beside the user's
    files)."""
    return out.with_name(f"{out.stem}.rows.geojson")


def _plan_rows_job(source: Path, out: Path, o: RowsPlanOptions, writing: tuple[Path | None, bool],
                   dose: DoseOptions | None) -> RowsJob:
    """``writing``: (``--mission`` path, ``overwrite``)."""
    mission_out, overwrite = writing
    spacing, height, speed, flow, takeoff = o.spacing, o.height, o.speed, o.flow, o.takeoff
    detect, world_rows, vehicle, tank_l = o.detect, o.world_rows, o.vehicle, o.tank_l
    fence_margin, home = o.fence_margin, o.home
    from vinecli.missions.patterns import spray_mission
    from vinecli.missions.qgc_export import export_plan, sortie_plan
    from vinecli.missions.qgc_format import vehicle_nozzle_flow_lps, write_plan
    from vinecli.names import name_from
    from vinecli.vehicle import load_vehicle

    det: RowDetection | None = None
    frame: RowFrame | None
    if source.is_dir():
        from vinecli.rows.source import detect_rows_on_grid, world_frame
        from vinecli.world import load_world

        w = load_world(source)
        canopy = CanopySource(world_dir=source, world_rows=not detect, grid=w.terrain.grid)
        veh = w.vehicle if vehicle is None else load_vehicle(vehicle)
        origin, frame = w.origin, world_frame(source)
        start = home or (w.spawn_enu[0], w.spawn_enu[1])
        home3 = (start[0], start[1], w.terrain_height(*start))
        if world_rows and not w.vine_rows_enu:
            raise InputError("the world has no rows", path=source)
        if w.vine_rows_enu and not detect:
            rows = [list(map(tuple, r)) for r in w.vine_rows_enu]
        elif w.terrain.grid is None:
            raise InputError("the world has flat terrain: no rows to detect", path=source)
        else:
            det = detect_rows_on_grid(w.terrain.grid, spacing_m=spacing)
            rows = det.rows
        fence = list(w.geofence.polygon_enu) if w.geofence is not None and w.geofence.polygon_enu else None
        xmin, ymin, xmax, ymax = w.terrain.bounds
        fence_name = "geofence" if fence else "terrain"
        margin = 1.0 if fence_margin is None else fence_margin
        fence = fence or [(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)]
        bounds: tuple[float, float, float, float] | None = w.terrain.bounds
        surface = w.terrain_height
        zones = w.no_spray_enu  # the grower's no-spray zones: the passes close their sections at them
    else:
        if world_rows:
            raise InputError("--world-rows needs a world directory", path=source)
        from vinecli.rows.source import detect_rows_in_dsm

        dsm = detect_rows_in_dsm(source, spacing_m=spacing)
        det, frame, rows = dsm.detection, dsm.frame, dsm.detection.rows
        canopy = CanopySource(dsm_path=source, dsm=dsm)
        if dsm.origin is None:
            raise InputError("the DSM has no CRS: a .plan needs latitude/longitude (build a world with origin: "
                             "and plan on it)", path=source)
        from vinecli.gis.georef import geo_frame

        origin = geo_frame(dsm.frame, dsm.origin)  # the plan's lat/lon through the DSM's CRS
        veh = load_vehicle(vehicle or DEFAULT_VEHICLE)
        fence = _bbox_polygon(dsm.grid["x"], dsm.grid["y"], np.isfinite(dsm.grid["z"]))
        fence_name = "DSM's data extent"
        margin = 0.0 if fence_margin is None else fence_margin
        bounds = None
        zones = []
        if home is not None:
            start = home
        elif rows:  # the end of the first row nearest the raster's south-west corner
            corner = fence[0]
            start = min((rows[0][0], rows[0][-1]), key=lambda p: (p[0] - corner[0]) ** 2 + (p[1] - corner[1]) ** 2)
        else:
            start = (0.0, 0.0)

        def surface(x: float, y: float) -> float:
            z = float(dsm.height(np.array([x]), np.array([y]))[0])
            return (z if np.isfinite(z) else dsm.median_z) - origin.alt

        home3 = (start[0], start[1], surface(*start))
    if not rows:
        raise InputError("no rows found (try --spacing)", path=source)
    georef = Georef(frame, origin)
    rates = None if dose is None else plan_segment_rates(dose, rows, georef, canopy,
                                                         spacing_m=det.spacing_m if det is not None else None)
    own_rows = len(rows) if source.is_dir() and not detect else None  # a world's own rows: a run finds their canopy
    dose_fields = mission_dose(dose, world_rows=own_rows) if dose is not None and mission_out is not None else None
    _check_options(veh, speed=speed, height=height, flow=flow, takeoff=takeoff, tank_l=tank_l)
    accel = plan_accel(veh)
    plan = plan_rows(rows, start, speed_mps=speed, accel_mps2=accel, fence_enu=fence, fence_margin_m=margin,
                     fence_name=fence_name, terrain_bounds=bounds, climb=(takeoff, veh.control.max_vel_up, veh.control.max_vel_down),
                     no_spray=zones)
    if not plan.legs:
        raise InputError(f"no rows left to plan ({'; '.join(plan.warnings)})", path=source)
    planned = [leg.points for leg in plan.legs if leg.spray]
    mission = spray_mission(planned, name=name_from(out.stem, "spray-rows"), height_m=height, speed_mps=speed, flow_lps=flow,
                            takeoff_m=takeoff, estimated_s=plan.time_s)
    nozzle = vehicle_nozzle_flow_lps(veh)
    tank = tank_l if tank_l is not None else (veh.tank.capacity_l if veh.tank is not None else 0.0)
    job = RowsJob(rows, det, plan, 1, warnings=list(plan.warnings))
    sorties = split_sorties(plan, flow, tank) if tank > 0 else [plan.legs]
    job.sorties = len(sorties)
    gj = _geojson_path(out)
    sortie_files = [out.with_name(f"{out.stem}.sortie-{k}.plan") for k in range(1, len(sorties) + 1)] \
        if len(sorties) > 1 else []
    targets = [out, gj, *sortie_files, *(rates_paths(out) if rates is not None else []),
               *([mission_out] if mission_out is not None else [])]
    _check_targets(targets, overwrite)
    # export_plan plans the mission's rows (rounded to mm, as --mission writes them) once more, on purpose:
    # OUT is then exactly the export of that mission. Reusing ``plan.legs`` would change the .plan of
    # detected rows (unrounded): the sub-mm shifts move waypoints and the terrain-following profile.
    write_plan(out, export_plan(mission, origin, home3, nozzle_max_flow_lps=nozzle, accel_mps2=accel, surface=surface))
    write_features(gj, rows_features(rows), georef, layer="rows")
    if rates is not None:
        write_rates(out, rates, georef)
        job.rates = rates
    for p, legs in zip(sortie_files, sorties if sortie_files else [], strict=True):  # one sortie: OUT alone
        write_plan(p, sortie_plan(legs, origin, home3, height_m=height, speed_mps=speed, flow_lps=flow,
                                  nozzle_max_flow_lps=nozzle, takeoff_m=takeoff, surface=surface, fence_enu=fence))
    if mission_out is not None:
        _write_mission(mission_out, mission, dose_fields, (planned, plan.time_s), o)
    job.files = targets
    return job


def _write_mission(path: Path, mission: MissionSpec, dose_fields: dict[str, object] | None,
                   planned: tuple[list[Polyline], float], o: RowsPlanOptions) -> None:
    """``--mission``: the plan's mission, with a dose on its spray phase (:func:`mission_dose`) instead of the flow of
    one rate when ``plan rows`` was given one; ``planned``: (the rows sprayed, in order; the plan's time, s)."""
    from vinecli.missions.patterns import spray_mission
    from vinecli.missions.spec_io import write_mission

    if dose_fields is not None:
        mission = spray_mission(planned[0], name=mission.name, height_m=o.height, speed_mps=o.speed,
                                takeoff_m=o.takeoff, estimated_s=planned[1], dose=dose_fields)
    write_mission(path, mission)
