"""Glue between THE loop and the spray transport model: build, run in bulk, rasterise.

The loop owns a :class:`~vinecli.spray.deposition.SprayEmitter` and appends one record per
step with the sprayer on; :func:`deposit` runs :func:`~vinecli.spray.deposition.transport` on
all of them after the loop and rasterises onto a grid over the sprayed path and the rows.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from vinecli.specs.vehicle import VehicleSpec
from vinecli.specs.wind import WindSpec
from vinecli.spray.deposit_grid import GridSpec, flat_height, grid_for, rasterise_discs
from vinecli.spray.deposition import DepositionConfig, Parcels, SprayEmitter, SprayerGeometry, transport
from vinecli.spray.nozzle_pattern import inner_radius
from vinecli.world.model import World

__all__ = ["FAR_MAP_RADIUS_M", "DepositionResult", "deposit"]

#: the widest disc a far-field drift parcel is drawn on in deposition.tif, m (within the map's 15 m margin the
#: far field's landing bins are at most ~2 m wide, their discs ~4 m)
FAR_MAP_RADIUS_M = 4.0


@dataclass
class DepositionResult:
    """Deposited volume on the grid (L per cell, (ny, nx), row 0 south) and the balance, L."""

    grid: GridSpec
    volume_l: np.ndarray
    valid: np.ndarray  # (ny, nx) bool: the cell lies on the terrain
    parcels: Parcels
    emitted_l: float
    on_grid_l: float
    off_grid_l: float
    config: DepositionConfig
    transport_s: float  # wall time of transport + rasterising, s
    sprayer: dict[str, object]
    geometry: SprayerGeometry | None = None  # size classes etc. the parcels refer to (spray budget)
    wind_xy: tuple[float, float] = (0.0, 0.0)  # volume-weighted mean horizontal wind while spraying, m/s ENU

    @property
    def balance_error(self) -> float:
        """|emitted - on grid - off grid| / emitted (0 when nothing was emitted)."""
        if self.emitted_l <= 0.0:
            return 0.0
        return abs(self.emitted_l - self.on_grid_l - self.off_grid_l) / self.emitted_l

    def rate_lpha(self) -> np.ndarray:
        """Application rate per cell, L/ha (float64, NaN off the terrain)."""
        r = self.volume_l * (1e4 / (self.grid.cell * self.grid.cell))
        return np.where(self.valid, r, np.nan)


def deposit(emitter: SprayEmitter, world: World, veh: VehicleSpec, wind_spec: WindSpec, seed: int,
            config: DepositionConfig | None = None) -> DepositionResult:
    """Transport everything ``emitter`` recorded and rasterise it over the world's terrain."""
    t0 = time.perf_counter()
    cfg = config or DepositionConfig()
    if config is None and math.isfinite(getattr(world, "obukhov_m", math.inf)):  # the world's air: its stability
        cfg = dataclasses.replace(cfg, obukhov_m=float(world.obukhov_m))
    canopy = world.canopy_model() if config is None else None
    if canopy is not None and canopy.has_foliage:  # the rows' hedges lift the far field's wind profile
        cfg = dataclasses.replace(cfg, displacement_m=canopy.displacement_m)
    ter = world.terrain
    gr = ter.grid
    height = gr.heights if gr is not None else flat_height(ter.flat_z)
    geo = SprayerGeometry.from_vehicle(veh, world.air_density)
    records = emitter.array()
    parcels = transport(records, geo, height, wind_spec, world.air_density, seed, cfg, float(world.gravity))
    vol = records[:, 15]
    wsum = float(vol.sum())
    wind_xy = ((float(vol @ records[:, 11]) / wsum, float(vol @ records[:, 12]) / wsum) if wsum > 0 else (0.0, 0.0))
    rows_xy = [tuple(p) for row in world.vine_rows_enu for p in row]
    footprint = float(parcels.radius[:parcels.primaries].max()) if parcels.primaries else 0.0
    # the far field's parcels (spray/surface_layer.py) stand for landing bins up to tens of metres wide far
    # downwind, mostly beyond the map: drawn on discs of at most the spray's own footprint or FAR_MAP_RADIUS_M (the
    # map keeps its cells; what they carry is counted on or off the map all the same)
    radius = np.minimum(parcels.radius, max(footprint, FAR_MAP_RADIUS_M))
    grid = grid_for(parcels.path_xy, rows_xy, tuple(ter.bounds), cfg.cell_m, cfg.margin_m, cfg.max_cells,
                    footprint_m=float(radius.max()) if radius.size else 0.0, max_fft_cells=cfg.max_fft_cells)
    vol, off = rasterise_discs(grid, parcels.x, parcels.y, parcels.vol, radius,
                               inner=inner_radius(radius, parcels.ring_r))  # hollow cones' rings
    xc, yc = grid.centres()
    bx0, by0, bx1, by1 = ter.bounds
    valid = ((xc >= bx0) & (xc <= bx1))[None, :] & ((yc >= by0) & (yc <= by1))[:, None]
    sprayer = {
        "nozzles": [n.model_dump(mode="json") for n in veh.sprayer.nozzles],
        "droplets": veh.sprayer.droplets.model_dump(mode="json"),
        "class_diameters_um": [round(float(d) * 1e6, 2) for d in geo.diam_m],
        "class_terminal_velocity_mps": [round(float(v), 4) for v in geo.v_t],
        "prop_radius_m": geo.rotor_radius_m,
    }
    return DepositionResult(grid=grid, volume_l=vol, valid=valid, parcels=parcels, emitted_l=parcels.emitted_l,
                            on_grid_l=float(vol.sum()), off_grid_l=off, config=cfg,
                            transport_s=time.perf_counter() - t0, sprayer=sprayer, geometry=geo, wind_xy=wind_xy)
