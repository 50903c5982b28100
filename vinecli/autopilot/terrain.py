"""What the built-in autopilot knows of the terrain: a map and, where the vehicle has one, its
rangefinder. World ENU, SI units.

* :class:`TerrainDatabase`: the terrain map the autopilot is given, as a planner loads a DEM: the
  world's height grid (``terrain/grid.npz`` of a built world; a flat world: its plane), with its
  extent. The simulator hands it over in :class:`~vinecli.autopilot.base.AutopilotContext`; it is
  data, not a view of the simulation.
* :class:`TerrainSense`: the terrain the autopilot flies by. Without a rangefinder, the map (no map:
  the ground under home, flat). With one, the map corrected by the measured distance, as PX4's EKF2
  terrain estimator does it: each valid reading gives the terrain height at the point it hit,
  ``z_sensor + d u_z`` (estimated position + the sensor's lever arm, ``u`` its axis), and a one-state
  Kalman filter tracks ``offset`` = measured terrain - map there (process noise ``EKF2_TERR_NOISE`` and
  ``EKF2_TERR_GRAD`` times the horizontal speed, measurement noise the sensor's σ plus
  ``EKF2_RNG_SFE`` of the distance, innovation gate ``EKF2_RNG_GATE``). The terrain at (x, y) is then
  ``map(x, y) + offset`` (no map: the measured terrain under the vehicle, flat). On the ground a
  reading below the sensor's minimum range counts as the sensor's ground clearance (EKF2_MIN_RNG).
  The measured distance is valid for 5 s after the last fused reading (EKF2's terrain timeout).

The height above the ground (:attr:`TerrainSense.height_agl`) is that of the skids, as the run's
recorded ``height_agl_m``.
"""

from __future__ import annotations

import math
from typing import ClassVar

from vinecli.frames import QuatXYZW, Vec3, quat_from_euler, quat_rotate
from vinecli.specs.vehicle import RangefinderSpec
from vinecli.terrain.grid import TerrainGrid
from vinecli.types import RangeSample

_NAN = float("nan")


class TerrainDatabase:
    """A terrain map: heights (ENU z, m) on a grid (bilinear), or a flat plane at ``flat_z``."""

    def __init__(self, grid: TerrainGrid | None, flat_z: float = 0.0,
                 bounds: tuple[float, float, float, float] | None = None) -> None:
        self.grid = grid
        self.flat_z = flat_z
        self.bounds = bounds if bounds is not None or grid is None else grid.bounds  # xmin, ymin, xmax, ymax

    def height(self, x: float, y: float) -> float:
        """Terrain z (ENU m) at (x, y); the grid's edge value outside it."""
        g = self.grid
        return self.flat_z if g is None else g.height(x, y)


class TerrainSense:
    """The terrain the autopilot flies by (see the module docstring): :meth:`height` at any point,
    :attr:`height_agl` and :attr:`dist_bottom` under the vehicle after each :meth:`update`."""

    TERR_NOISE: ClassVar[float] = 5.0  # EKF2_TERR_NOISE, m/s
    TERR_GRAD: ClassVar[float] = 0.5  # EKF2_TERR_GRAD, m/m
    RNG_SFE: ClassVar[float] = 0.05  # EKF2_RNG_SFE, m/m
    RNG_GATE: ClassVar[float] = 5.0  # EKF2_RNG_GATE, σ
    VALID_US: ClassVar[int] = 5_000_000

    def __init__(self, db: TerrainDatabase | None, rangefinder: RangefinderSpec | None, home_ground_z: float,
                 landing_gear_m: float) -> None:
        self.db = db
        self.gear = landing_gear_m
        self.home_ground_z = home_ground_z
        self.has_range = rangefinder is not None
        self.offset = 0.0 if db is not None else home_ground_z  # m, terrain - map (no map: the terrain z)
        self.offset_var = 0.0
        self._init = False
        self._t_fused_us = -self.VALID_US
        self._t_us = 0
        self.height_agl = 0.0
        self.dist_bottom = _NAN  # m, from the fused rangefinder readings (NaN: none valid)
        if rangefinder is not None:
            r, p, y = rangefinder.mount.rpy_deg
            self.axis_flu: Vec3 = quat_rotate(quat_from_euler(math.radians(r), math.radians(p), math.radians(y)),
                                              (0.0, 0.0, -1.0))
            pm = rangefinder.mount.position_m
            self.r_flu: Vec3 = (float(pm[0]), float(pm[1]), float(pm[2]))
            self.noise_var = max(rangefinder.noise_m, 0.01) ** 2
            # level on the ground: distance from the sensor along its axis to the skids' plane (EKF2_MIN_RNG)
            az = self.axis_flu[2]
            self.ground_range = (self.r_flu[2] + landing_gear_m) / -az if az < -1e-3 else _NAN
        else:
            self.axis_flu = (0.0, 0.0, -1.0)
            self.r_flu = (0.0, 0.0, 0.0)
            self.noise_var = 0.0
            self.ground_range = _NAN

    def _map(self, x: float, y: float) -> float:
        db = self.db
        return db.height(x, y) if db is not None else 0.0

    def height(self, x: float, y: float) -> float:
        """Terrain z (ENU m) the autopilot believes at (x, y)."""
        return self._map(x, y) + self.offset

    def update(self, t_us: int, sample: RangeSample | None, pos: Vec3, quat: QuatXYZW, vel: Vec3,
               on_ground: bool) -> None:
        """Fuse a rangefinder ``sample`` (if any) taken at the estimated pose (``pos`` ENU m, ``quat``
        FLU -> ENU, ``vel`` ENU m/s); ``on_ground``: the land detector says landed."""
        dt = (t_us - self._t_us) * 1e-6
        self._t_us = t_us
        if self.has_range:
            if self._init and dt > 0.0:
                vh = vel[0] * vel[0] + vel[1] * vel[1]
                self.offset_var += (self.TERR_NOISE * dt) ** 2 + self.TERR_GRAD * self.TERR_GRAD * dt * dt * vh
            if sample is not None:
                d = sample.distance_m if sample.valid else (self.ground_range if on_ground else _NAN)
                if d == d:
                    self._fuse(t_us, d, pos, quat)
            if t_us - self._t_fused_us >= self.VALID_US:
                self.dist_bottom = _NAN
        self.height_agl = pos[2] - self.height(pos[0], pos[1]) - self.gear
        if self.has_range and t_us - self._t_fused_us < self.VALID_US:
            self.dist_bottom = self.height_agl

    def _fuse(self, t_us: int, d: float, pos: Vec3, quat: QuatXYZW) -> None:
        """One distance ``d`` (m, along the axis) into the terrain offset."""
        rx, ry, rz = quat_rotate(quat, self.r_flu)
        ux, uy, uz = quat_rotate(quat, self.axis_flu)
        meas = pos[2] + rz + d * uz - self._map(pos[0] + rx + d * ux, pos[1] + ry + d * uy)
        r = self.noise_var + (self.RNG_SFE * d) ** 2
        if not self._init:
            self.offset, self.offset_var, self._init = meas, r, True
            self._t_fused_us = t_us
            return
        s = self.offset_var + r
        innov = meas - self.offset
        if innov * innov > self.RNG_GATE * self.RNG_GATE * s:
            return
        k = self.offset_var / s
        self.offset += k * innov
        self.offset_var *= 1.0 - k
        self._t_fused_us = t_us
