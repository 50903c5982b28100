"""What the simulator hands an autopilot backend, apart from the per-step observations: the context
of the run (mission, airframe, home, the world's terrain map, the perfect estimator of ground-truth
runs) and the rangefinder it samples each step. World ENU, SI units.
"""

from __future__ import annotations

from collections.abc import Callable

from vinecli.autopilot.base import AutopilotContext
from vinecli.autopilot.terrain import TerrainDatabase
from vinecli.flight.rangefinder import Rangefinder, make_rangefinder
from vinecli.frames import Vec3
from vinecli.sim.perfect_estimator import PerfectEstimator
from vinecli.sim.setup import PreparedRun
from vinecli.world.model import World


def terrain_database(world: World) -> TerrainDatabase:
    """The world's terrain map as a planner loads it: its height grid (read-only), or its plane."""
    t = world.terrain
    b = t.bounds
    return TerrainDatabase(t.grid, t.flat_z, (float(b[0]), float(b[1]), float(b[2]), float(b[3])) if len(b) == 4 else None)


def autopilot_context(run: PreparedRun, home: Vec3, dt_us: int, seed: int,
                      should_stop: Callable[[], bool] | None = None) -> AutopilotContext:
    """The context of one run: with the simulator's perfect estimator when the mission flies on
    ground truth (``truth: true`` / ``--truth``); ``should_stop``: the run's stop flag (a backend polls it in
    long waits)."""
    db = terrain_database(run.world)
    return AutopilotContext(
        mission=run.flight,
        vehicle=run.vehicle,
        origin=run.world.origin,
        home_enu=home,
        physics_dt_us=dt_us,
        vine_rows_enu=run.rows,
        geofence=run.geofence,
        terrain=db,
        seed=seed,
        terrain_bounds=db.bounds,
        estimator=PerfectEstimator() if run.flight.truth else None,
        should_stop=should_stop,
        air_density_kgm3=float(run.world.air_density),
        no_spray_enu=tuple(tuple(p) for p in run.world.no_spray_enu),
        segment_rates=dict(run.segment_rates),
    )


def world_rangefinder(world: World, run: PreparedRun, seed: int) -> Rangefinder | None:
    """The vehicle's rangefinder over the world's terrain (its own noise stream), or None."""
    grid = world.terrain.grid
    return make_rangefinder(run.vehicle.sensors.rangefinder, grid.height if grid is not None else world.terrain.height,
                            grid.max_slope() if grid is not None else 0.0, seed)
