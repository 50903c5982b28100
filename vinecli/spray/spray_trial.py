"""Field-trial set-ups for the spray budget without a flight: straight passes at a steady state.

A trial is what a spray paper describes: a vehicle (mass, rotors, nozzles, drop spectrum) flying
straight passes at a height, speed and flow over a field of hedges, in a wind. :func:`pass_records`
turns one pass into the emission records the loop would write (:data:`~vinecli.spray.deposition.EMIT_COLUMNS`,
level flight, thrust = weight); :func:`run_trial` moves them with the same transport and budget
every run uses. The published comparisons (tests/spray/test_published_trials.py,
benchmarks/published_trials.py) and the direction tests are built on it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.specs.wind import WindSpec
from vinecli.spray.budget import BudgetConfig, SprayBudget, spray_budget
from vinecli.spray.canopy import Canopy, Hedge, row_spacing
from vinecli.spray.deposit_grid import flat_height
from vinecli.spray.deposition import DepositionConfig, Parcels, SprayerGeometry, fan_axes_flu, transport
from vinecli.spray.droplets import AIR_VISCOSITY, WATER_DENSITY, size_classes_m, terminal_velocity
from vinecli.spray.nozzle_pattern import PATTERN_CODES

__all__ = ["Trial", "TrialVehicle", "pass_records", "run_trial", "vineyard_rows"]


@dataclass(frozen=True)
class TrialVehicle:
    """A multirotor as a spray paper describes it: mass (kg), rotors, nozzles (body FLU m), cone (deg), spectrum."""

    mass_kg: float
    n_rotors: int
    prop_diameter_m: float
    nozzles_flu: tuple[tuple[float, float, float], ...]
    cone_angle_deg: float
    vmd_um: float
    gsd: float
    classes: int = 5
    rotor_plane_z: float = 0.05
    #: the rotor hubs' distance from the axis, m (None: the propellers' tips 10 % of a radius apart, R / sin(π/n) · 1.1)
    arm_m: float | None = None
    #: every nozzle's spray pattern (full_cone, hollow_cone, flat_fan; spray/nozzle_pattern.py) and a fan's sheet axis,
    #: deg from the body's forward axis towards its left
    pattern: str = "full_cone"
    fan_axis_deg: float = 90.0

    def geometry(self, air_density: float) -> SprayerGeometry:
        d, frac = size_classes_m(self.vmd_um, self.gsd, self.classes)
        n = len(self.nozzles_flu)
        return SprayerGeometry(
            nozzles_flu=np.asarray(self.nozzles_flu, dtype=np.float64), shares=np.full(n, 1.0 / n),
            tan_half=np.full(n, math.tan(math.radians(self.cone_angle_deg) / 2.0)), diam_m=d, fractions=frac,
            v_t=terminal_velocity(d, WATER_DENSITY, air_density, AIR_VISCOSITY), n_rotors=self.n_rotors,
            rotor_radius_m=0.5 * self.prop_diameter_m, rotor_plane_z=self.rotor_plane_z,
            arm_m=self.arm_m if self.arm_m is not None else 0.55 * self.prop_diameter_m / math.sin(math.pi / self.n_rotors),
            pattern=np.full(n, PATTERN_CODES[self.pattern], dtype=np.int64), fan_axis_flu=fan_axes_flu([self.fan_axis_deg] * n))


# parameters: a straight pass as the published trials describe it: ends, height, speed, flow, thrust, wind,
# then the record clock with defaults
def pass_records(start_xy: tuple[float, float], end_xy: tuple[float, float], z_m: float, speed_mps: float,
                 flow_lps: float, thrust_n: float, wind_enu: tuple[float, float, float], t0: float = 0.0,
                 dt: float = 0.04) -> np.ndarray:
    """(N, 17) emission records of a straight level pass from ``start_xy`` to ``end_xy`` at CoM height ``z_m``."""
    p0, p1 = np.asarray(start_xy, float), np.asarray(end_xy, float)
    length = float(np.hypot(*(p1 - p0)))
    u = (p1 - p0) / length
    n = max(1, int(round(length / (speed_mps * dt))))
    t = t0 + (np.arange(n) + 0.5) * dt
    xy = p0 + np.outer((np.arange(n) + 0.5) * speed_mps * dt, u)
    yaw = math.atan2(u[1], u[0])
    rec = np.zeros((n, 17))
    rec[:, 0] = t
    rec[:, 1:3] = xy
    rec[:, 3] = z_m
    rec[:, 6], rec[:, 7] = math.sin(yaw / 2.0), math.cos(yaw / 2.0)
    rec[:, 8:10] = u * speed_mps
    rec[:, 11:14] = wind_enu
    rec[:, 14] = thrust_n
    rec[:, 15] = flow_lps * dt
    return rec


def vineyard_rows(n_rows: int, spacing_m: float, length_m: float, x0: float = 0.0) -> list[list[tuple[float, float]]]:
    """``n_rows`` straight north-south rows ``spacing_m`` apart from x = ``x0`` eastwards, ``length_m`` long from y = 0."""
    return [[(x0 + i * spacing_m, 0.0), (x0 + i * spacing_m, length_m)] for i in range(n_rows)]


@dataclass(frozen=True)
class Trial:
    """One trial: vehicle, field (rows + one hedge shape, or none), passes [(start, end)], flight and weather."""

    vehicle: TrialVehicle
    rows: Sequence[Sequence[tuple[float, float]]]
    passes: Sequence[tuple[tuple[float, float], tuple[float, float]]]
    height_m: float  # nozzle height above the ground, m
    speed_mps: float
    flow_lps: float
    applied_lpha: float
    wind_enu: tuple[float, float, float] = (0.0, 0.0, 0.0)
    hedge: tuple[float, float, float, float] | None = None  # base m, top m, width m, LAD m²/m³
    profile: tuple[float, ...] = (1.0,)
    air: tuple[float, float] | None = None  # temperature °C, relative humidity %
    air_density: float = 1.204
    seed: int = 0
    budget: BudgetConfig = field(default_factory=BudgetConfig)

    def canopy(self) -> Canopy | None:
        if self.hedge is None:
            return None
        b, t, w, a = self.hedge
        rows = tuple(tuple((float(p[0]), float(p[1])) for p in r) for r in self.rows)
        return Canopy(rows=rows, hedges=tuple(Hedge(i, b, t, w, a) for i in range(len(rows))), profile=self.profile,
                      source="given", spacing_m=row_spacing(self.rows))


def run_trial(trial: Trial) -> tuple[SprayBudget, Parcels]:
    """Transport every pass of ``trial`` over flat ground at z = 0 and return its budget and parcels."""
    veh = trial.vehicle
    geo = veh.geometry(trial.air_density)
    z_com = trial.height_m - min(n[2] for n in veh.nozzles_flu)
    thrust = veh.mass_kg * STANDARD_GRAVITY
    recs, t0 = [], 0.0
    for a, b in trial.passes:
        r = pass_records(a, b, z_com, trial.speed_mps, trial.flow_lps, thrust, trial.wind_enu, t0)
        recs.append(r)
        t0 = float(r[-1, 0]) + 10.0
    records = np.vstack(recs)
    wind = WindSpec.model_validate({"law": {"type": "constant", "velocity_enu": list(trial.wind_enu)}})
    canopy = trial.canopy()
    config = DepositionConfig(displacement_m=canopy.displacement_m if canopy is not None else 0.0)
    parcels = transport(records, geo, flat_height(0.0), wind, trial.air_density, trial.seed, config)
    budget = spray_budget(parcels, geo.diam_m, geo.v_t, canopy, trial.rows, row_spacing(trial.rows),
                          trial.applied_lpha, (trial.wind_enu[0], trial.wind_enu[1]), trial.air, trial.budget)
    return budget, parcels
