"""What a run may hold in memory, worked out at load: a mission that cannot fit is refused before it
runs, with the numbers, instead of exhausting a shared machine half-way.

A run keeps its time series (``max_duration_s`` × ``record_rate_hz`` rows of every column, twice at the
end: the recorder's chunks and the columns handed to the writer), the spray records and, after the
flight, the transported parcels, the deposition grid and the padded disc convolution
(:mod:`vinecli.spray.deposit_grid`, sized by :func:`~vinecli.spray.deposit_grid.grid_for` for the
highest the mission flies over the whole terrain), and the spray budget (:mod:`vinecli.spray.budget`: its
per-parcel arrays, the canopy points of every hedge a parcel's footprint reaches, the canopy maps over the
hedges' cells of the grid, the release row of every emission group). :func:`check_run_memory` adds these upper bounds to
what the process holds anyway and refuses (InputError, exit 2, the numbers in one line) a mission whose
bound exceeds :data:`RUN_MEMORY_LIMIT_MB` before anything is flown or written. The per-item sizes were
measured (``benchmarks/deposition_memory.py``, tracemalloc on the transport and the emitter).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from vinecli.errors import InputError
from vinecli.sim.row import timeseries_columns
from vinecli.specs.mission import MissionSpec
from vinecli.specs.vehicle import VehicleSpec
from vinecli.spray.canopy import hedge_window, row_spacing
from vinecli.spray.deposit_grid import FFT_BYTES_PER_CELL, GridSpec, fft_cells, grid_for
from vinecli.spray.deposition import FAR_BINS, LIFT_BIN_S, MAX_FAR_PARCELS, DepositionConfig
from vinecli.world.model import World

__all__ = ["RUN_MEMORY_LIMIT_MB", "MemoryEstimate", "check_run_memory", "estimate_run_memory"]

#: the most one run may hold (peak resident set), MB
RUN_MEMORY_LIMIT_MB = 1536.0
#: what a run process holds besides its own data: interpreter, PyBullet, numpy/scipy/pyarrow (measured 112-121 MB
#: for a whole run without the sprayer, benchmarks/deposition_memory.py), MB
BASE_MB = 250.0
#: copies of the time series alive at the end of a run (recorder chunks, the columns for the writer)
TIMESERIES_COPIES = 2
#: one spray record of the loop (a tuple of 17 floats), bytes; one every 0.04 s of spraying at most
EMIT_RECORD_BYTES = 600
#: the transport's arrays per parcel (one per record, nozzle and droplet class), bytes (measured 313)
PARCEL_BYTES = 340
#: the deposition grid's arrays per cell (volume, rate, masks, the GeoTIFF, the metrics' bands), bytes
GRID_BYTES_PER_CELL = 64
#: the spray budget's arrays per primary parcel (merged, the outwash's lifted parcels, the five destinations),
#: bytes (measured 65-380 at 2-10 m with tracemalloc, tests/safety/test_deposition_memory.py)
BUDGET_BYTES_PER_PARCEL = 300
#: the canopy points and interception temporaries per primary parcel and hedge its footprint reaches, bytes
#: (measured: 770 per parcel at 400 m over 9 hedges)
BUDGET_BYTES_PER_PARCEL_HEDGE = 60
#: the canopy maps per cell of the hedges' window (deposit, leaf area, µL/cm², L/ha, mask, the GeoTIFF), bytes
#: (measured 43)
CANOPY_BYTES_PER_CELL = 64
MB = 1e6


@dataclass(frozen=True)
class MemoryEstimate:
    """Upper bounds of what a run holds, MB, and the figures behind them."""

    base_mb: float
    timeseries_mb: float
    rows: int
    columns: int
    spray_mb: float
    grid_mb: float
    grid_cell_m: float
    height_m: float
    budget_mb: float = 0.0

    @property
    def total_mb(self) -> float:
        return self.base_mb + self.timeseries_mb + self.spray_mb + self.grid_mb + self.budget_mb


def _heights(value: Any, key: str = "") -> Iterator[float]:
    """Every height above ground a phase mapping names (``*altitude*``/``*height*`` keys, waypoint z)."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _heights(v, k)
    elif isinstance(value, (list, tuple)):
        if key == "waypoints":
            yield from (float(w[2]) for w in value if isinstance(w, (list, tuple)) and len(w) == 3)
        else:
            for v in value:
                yield from _heights(v, key)
    elif isinstance(value, (int, float)) and not isinstance(value, bool) and ("altitude" in key or "height" in key):
        yield float(value)


def _sprays(mission: MissionSpec) -> bool:
    """Can the mission switch the sprayer on (a spray phase, or a phase with a flow above 0)?"""
    return any(ph.type == "spray" or (getattr(ph, "flow_lps", None) or 0.0) > 0.0 for ph in mission.phases)


def _flown_area(mission: MissionSpec, world: World) -> list[tuple[float, float]]:
    """Corners of where the vehicle may fly (ENU m): the geofence polygon (mission > world), else the terrain."""
    fence = mission.geofence or world.geofence
    if fence is not None and fence.polygon_enu:
        return [tuple(p) for p in fence.polygon_enu]  # type: ignore[misc]
    x0, y0, x1, y1 = world.terrain.bounds
    return [(x0, y0), (x1, y1)]


def estimate_run_memory(mission: MissionSpec, vehicle: VehicleSpec, world: World,
                        config: DepositionConfig | None = None) -> MemoryEstimate:
    """Upper bounds (MB) of the memory a run of ``mission`` with ``vehicle`` in ``world`` can need."""
    rate = min(mission.record_rate_hz, world.physics_rate_hz)
    rows = int(mission.max_duration_s * rate) + 2
    cols = len(timeseries_columns(vehicle.n_rotors))
    ts_mb = TIMESERIES_COPIES * rows * cols * 8 / MB
    grid = world.terrain.grid
    base_mb = BASE_MB + (3 * grid.z.nbytes / MB if grid is not None else 0.0)
    spray_mb = grid_mb = budget_mb = cell = 0.0
    height = max(_heights([ph.model_dump() for ph in mission.phases]), default=0.0)
    if vehicle.tank is not None and _sprays(mission):
        cfg = config or DepositionConfig()
        zmin, zmax = world.terrain.z_range
        height += max(zmax - zmin, 0.0)
        records = math.ceil(mission.max_duration_s / cfg.group_s) + 1
        parcels = records * len(vehicle.sprayer.nozzles) * vehicle.sprayer.droplets.classes
        spray_mb = (records * EMIT_RECORD_BYTES + parcels * PARCEL_BYTES) / MB
        tan_half = max(math.tan(math.radians(n.cone_angle_deg) / 2.0) for n in vehicle.sprayer.nozzles)
        footprint = height * tan_half
        g = grid_for(np.asarray(_flown_area(mission, world), dtype=np.float64), [], world.terrain.bounds, cfg.cell_m, cfg.margin_m, cfg.max_cells,
                     footprint_m=footprint, max_fft_cells=cfg.max_fft_cells)
        cell = g.cell
        grid_mb = (g.nx * g.ny * GRID_BYTES_PER_CELL + fft_cells(g.nx, g.ny, footprint, g.cell) * FFT_BYTES_PER_CELL) / MB
        budget_mb = _budget_mb(world, g, parcels, records, footprint)
    return MemoryEstimate(base_mb, ts_mb, rows, cols, spray_mb, grid_mb, cell, height, budget_mb)


def _budget_mb(world: World, grid: GridSpec, parcels: int, records: int, footprint_m: float) -> float:
    """Upper bound of the spray budget's memory (MB) for ``parcels`` primary parcels of ``records`` emission groups
    landing on discs up to ``footprint_m`` (m) on ``grid``."""
    canopy = world.canopy_model()
    reach = 0
    if canopy is not None and canopy.has_foliage:
        spacing = row_spacing(canopy.rows)
        width = max((h.width_m for h in canopy.hedges), default=0.0)
        across = 2.0 * footprint_m + width
        reach = len(canopy.hedges) if not spacing > 0 else min(len(canopy.hedges), int(across / spacing) + 2)
    win = hedge_window(grid, canopy)
    n_rows = len(world.vine_rows_enu)
    # the far field's parcels (spray/deposition.py MAX_FAR_PARCELS): up to FAR_BINS per lifted parcel, merged over
    # LIFT_BIN_S, across every hedge (their discs reach tens of metres)
    far = min(MAX_FAR_PARCELS, math.ceil(parcels * FAR_BINS * DepositionConfig().group_s / LIFT_BIN_S))
    far_bytes = far * (PARCEL_BYTES + BUDGET_BYTES_PER_PARCEL + BUDGET_BYTES_PER_PARCEL_HEDGE * len(
        canopy.hedges if canopy is not None else ()))
    return (parcels * (BUDGET_BYTES_PER_PARCEL + BUDGET_BYTES_PER_PARCEL_HEDGE * reach)
            + win.nx * win.ny * CANOPY_BYTES_PER_CELL + 16 * n_rows * records + far_bytes) / MB


def check_run_memory(mission: MissionSpec, vehicle: VehicleSpec, world: World, *, path: Any = None,
                     config: DepositionConfig | None = None) -> MemoryEstimate:
    """The estimate; InputError (exit 2) naming ``path`` and the numbers when it exceeds the limit."""
    e = estimate_run_memory(mission, vehicle, world, config)
    if e.total_mb <= RUN_MEMORY_LIMIT_MB:
        return e
    parts = [f"time series {e.timeseries_mb:.0f} MB (max_duration_s {mission.max_duration_s:g} s × record_rate_hz "
             f"{mission.record_rate_hz:g} Hz = {e.rows:,} rows × {e.columns} columns)"]
    if e.spray_mb or e.grid_mb:
        parts.append(f"spray records and parcels {e.spray_mb:.0f} MB, deposition grid {e.grid_mb:.0f} MB "
                     f"({e.grid_cell_m:g} m cells up to {e.height_m:g} m above ground), spray budget "
                     f"{e.budget_mb:.0f} MB")
    raise InputError(f"the run could need {e.total_mb / 1e3:.1f} GB ({', '.join(parts)}, {e.base_mb:.0f} MB to run), "
                     f"more than the {RUN_MEMORY_LIMIT_MB / 1e3:.1f} GB a run may use: lower max_duration_s or "
                     "record_rate_hz", path=path)
