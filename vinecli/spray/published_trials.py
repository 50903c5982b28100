"""Published field trials of multirotor spraying over vineyards, set up as the papers describe them, and the
model's collector readings to compare with the papers' (tests/spray/test_published_trials.py,
benchmarks/published_trials.py, docs/budget.md "Compared with field trials").

Biglia et al. 2022, "UAV-spray application in vineyards: flight modes and spray system adjustment
effects on canopy deposit, coverage, and off-target losses", Sci. Total Environ. 845:157292:

* vehicle: DJI Matrice 600 Pro hexacopter (21 in propellers; 9.5 kg with its batteries, + 2.8 kg
  sprayer + half of the 5 L tank on average), two nozzles 910 mm apart, 175 mm below the rotor
  plane (§2.1); flown 3 m above the ground at 1 and 3 m/s, 2.4 L/min (1.2 L/min for the 2-way
  broadcast), Table 1;
* drops (Table 2, Malvern Spraytec): band mode hollow cones, 60°: conventional HCI 60 03 (Dv0.1 67,
  VMD 145, Dv0.9 281 µm), air inclusion HCA 60 03 (203 / 597 / 1238 µm); broadcast flat fans, 110°:
  SF 110 03 (77 / 159 / 313), AFC 110 03 (121 / 306 / 669), SF 110 015 (70 / 140 / 265),
  AFC 110 015 (128 / 298 / 646). Log-normal fitted to Dv0.1 and Dv0.9 (GSD = (Dv0.9/Dv0.1)^(1/2.563));
  the hollow cones land their drops on a ring, the flat fans on a line (:mod:`vinecli.spray.nozzle_pattern`),
  the fans' sheets along the line of the two nozzles (as on a boom: across the flight line in broadcast mode);
* vineyard (§2.4): VSP, cv. Barbera, BBCH 89, rows 2.5 m apart, 62 m long; vine height 2.21 m,
  vegetative strip 1.68 m, canopy width 0.55 m, LAI 1.5-1.9 (LAD 4.6 m²/m³);
* weather (Table A1): per configuration (temperature, humidity, mean wind and its direction);
  rows at azimuth 146°;
* collectors (§2.3): filter papers on both faces of leaves at 0.7, 1.3 and 1.9 m and three depths
  (both edges and the middle of the canopy) at three places along the row; Petri dishes under the
  row and 0.625 and 1.25 m either side; deposits standardised to 250 µL per cm travelled (Eq. 3).

Reported (standardised, µL/cm²): canopy, band with conventional nozzles 0.237 (§3.1, Fig. 5);
canopy, band 0.161 and broadcast 0.052 (abstract; all nozzles and speeds); ground losses, band 0.246,
1-way broadcast 0.53, 2-way broadcast 0.558 (§3.3, Fig. 9; abstract: broadcast 0.544).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from vinecli.spray.collectors import collector_deposit
from vinecli.spray.deposition import FAR_WALL_JET
from vinecli.spray.spray_trial import Trial, TrialVehicle, run_trial, vineyard_rows

__all__ = ["BIGLIA_2022", "CONFIGS", "RAUTMANN_2001", "BigliaConfig", "bench_trial_mg1p", "biglia_trial", "drift_trial",
           "reading", "vineyard_bench_trial"]

ROW_AZIMUTH_DEG = 146.0
SPACING_M = 2.5
ROW_LENGTH_M = 62.0
HEDGE = (0.53, 2.21, 0.55, 4.6)  # base, top, width (m), LAD m²/m³
STD_UL_PER_CM = 250.0  # the paper's standard application, µL per cm travelled

#: what the paper reports, µL/cm² (standardised)
BIGLIA_2022 = {
    "canopy_band_conventional": 0.237, "canopy_band": 0.161, "canopy_broadcast": 0.052,
    "ground_band": 0.246, "ground_broadcast_1way": 0.53, "ground_broadcast_2way": 0.558,
}


@dataclass(frozen=True)
class BigliaConfig:
    """One of the paper's configurations T1-T12 (Tables 1, 2, A1)."""

    name: str
    mode: str  # "band" | "1-way" | "2-way"
    conventional: bool
    speed_mps: float
    flow_lpm: float
    cone_deg: float
    dv: tuple[float, float, float]  # Dv0.1, Dv0.5, Dv0.9 µm
    temperature_c: float
    rh_pct: float
    wind_mps: float
    wind_from_deg: float


CONFIGS = (
    BigliaConfig("T1", "1-way", True, 1.0, 2.4, 110.0, (77, 159, 313), 12.1, 71.1, 1.02, 127),
    BigliaConfig("T2", "1-way", True, 3.0, 2.4, 110.0, (77, 159, 313), 20.0, 30.1, 1.17, 185),
    BigliaConfig("T3", "1-way", False, 1.0, 2.4, 110.0, (121, 306, 669), 21.8, 56.6, 0.73, 334),
    BigliaConfig("T4", "1-way", False, 3.0, 2.4, 110.0, (121, 306, 669), 20.9, 54.1, 0.36, 11),
    BigliaConfig("T5", "2-way", True, 1.0, 1.2, 110.0, (70, 140, 265), 20.4, 54.9, 0.85, 54),
    BigliaConfig("T6", "2-way", True, 3.0, 1.2, 110.0, (70, 140, 265), 21.3, 23.6, 1.53, 111),
    BigliaConfig("T7", "2-way", False, 1.0, 1.2, 110.0, (128, 298, 646), 15.9, 49.7, 1.32, 172),
    BigliaConfig("T8", "2-way", False, 3.0, 1.2, 110.0, (128, 298, 646), 19.4, 67.1, 0.95, 340),
    BigliaConfig("T9", "band", True, 1.0, 2.4, 60.0, (67, 145, 281), 21.6, 60.9, 0.56, 297),
    BigliaConfig("T10", "band", True, 3.0, 2.4, 60.0, (67, 145, 281), 23.5, 53.1, 0.71, 83),
    BigliaConfig("T11", "band", False, 1.0, 2.4, 60.0, (203, 597, 1238), 21.2, 23.9, 1.36, 100),
    BigliaConfig("T12", "band", False, 3.0, 2.4, 60.0, (203, 597, 1238), 25.0, 48.8, 0.95, 165),
)


def _gsd(dv: tuple[float, float, float]) -> float:
    return (dv[2] / dv[0]) ** (1.0 / (2.0 * 1.2816))


def biglia_trial(c: BigliaConfig, seed: int = 0) -> Trial:
    """The trial of configuration ``c``: rows along +y (north), the sampled row at x = 0 in the middle of nine."""
    rows = vineyard_rows(9, SPACING_M, ROW_LENGTH_M, x0=-4 * SPACING_M)
    # band: along the sampled row, the nozzles one behind the other; broadcast: across the rows at mid-length,
    # the nozzles side by side (the paper rotates the UAV so); 2-way: there and back on the same line
    if c.mode == "band":
        nozzles = ((0.455, 0.0, -0.175), (-0.455, 0.0, -0.175))
        passes = [((0.0, -5.0), (0.0, ROW_LENGTH_M + 5.0))]
    else:
        nozzles = ((0.0, 0.455, -0.175), (0.0, -0.455, -0.175))
        y = 0.5 * ROW_LENGTH_M
        passes = [((-11.0, y), (11.0, y))] + ([((11.0, y), (-11.0, y))] if c.mode == "2-way" else [])
    veh = TrialVehicle(mass_kg=9.5 + 2.8 + 2.5, n_rotors=6, prop_diameter_m=0.533, nozzles_flu=nozzles,
                       cone_angle_deg=c.cone_deg, vmd_um=c.dv[1], gsd=_gsd(c.dv), classes=7, rotor_plane_z=0.0,
                       arm_m=0.5665,  # the M600's diagonal wheelbase, 1133 mm (DJI)
                       pattern="hollow_cone" if c.mode == "band" else "flat_fan", fan_axis_deg=90.0)
    towards = math.radians(c.wind_from_deg + 180.0 - ROW_AZIMUTH_DEG)  # in the frame whose +y is the row direction
    wind = (c.wind_mps * math.sin(towards), c.wind_mps * math.cos(towards), 0.0)
    flow = c.flow_lpm / 60.0
    return Trial(vehicle=veh, rows=rows, passes=passes, height_m=3.0 - 0.175, speed_mps=c.speed_mps, flow_lps=flow,
                 applied_lpha=flow * 1e4 / (c.speed_mps * SPACING_M), wind_enu=wind, hedge=HEDGE,
                 air=(c.temperature_c, c.rh_pct), seed=seed)


def reading(c: BigliaConfig, seed: int = 0) -> dict[str, float]:
    """The model's standardised collector readings for configuration ``c`` (µL/cm²): canopy (mean of both leaf
    faces over the 27 paper positions) and ground (mean of the 15 dishes), and the budget fractions."""
    trial = biglia_trial(c, seed)
    budget, p = run_trial(trial)
    canopy = trial.canopy()
    landed = p.vol.copy()
    if trial.air is not None:  # the same evaporation the budget applies, per parcel
        from vinecli.spray.evaporation import evaporation_constant, remaining_fraction

        geo = trial.vehicle.geometry(trial.air_density)
        lam = evaporation_constant(geo.diam_m, geo.v_t, *trial.air)[p.cls]
        landed = p.vol * remaining_fraction(geo.diam_m[p.cls], lam, p.t_fall)
    geo = trial.vehicle.geometry(trial.air_density)
    vt = geo.v_t[p.cls]
    along = (0.25 * ROW_LENGTH_M, 0.5 * ROW_LENGTH_M, 0.75 * ROW_LENGTH_M) if c.mode == "band" else (
        0.5 * ROW_LENGTH_M - 0.8, 0.5 * ROW_LENGTH_M, 0.5 * ROW_LENGTH_M + 0.8)
    leaf_pts = np.array([(s, a, z) for a in along for z in (0.7, 1.3, 1.9) for s in (-0.2, 0.0, 0.2)])
    dish_pts = np.array([(s, a, 0.0) for a in along for s in (-1.25, -0.625, 0.0, 0.625, 1.25)])
    args = (p.x, p.y, landed, p.radius, p.vx_land, p.vy_land, p.vz_land, vt)
    plume = (p.reach, p.wake_var, p.release_h)
    w_top = p.downwash_at(HEDGE[1])  # the wake entering the hedge's top
    # the wall jet's drops came down in their primary's wake through the canopy before the outwash lifted them (what
    # the leaves did not catch): the leaves see them with their primary, not where the far field lands them
    wall = (p.far_kind == FAR_WALL_JET) & (p.source >= 0)
    carried = np.bincount(p.source[wall], weights=landed[wall], minlength=p.vol.size)
    leaf_vol = np.where(wall, 0.0, landed + carried)
    leaf_args = (p.x, p.y, leaf_vol, *args[3:])
    leaf = collector_deposit(*leaf_args, leaf_pts, canopy, width_m=0.12, plume=plume, w_top=w_top, ring_r=p.ring_r)
    # the dishes get the wall jet's drops where the far field lands them, less what the canopy caught on their way down
    dish_vol = np.where(wall, landed * (1.0 - budget.caught_in_wake), landed)
    dish = collector_deposit(p.x, p.y, dish_vol, *args[3:], dish_pts, canopy, width_m=None, plume=plume, w_top=w_top,
                             ring_r=p.ring_r)
    # to 250 µL per cm of the line: the 2-way configurations apply their dose in two passes at half the flow
    # (Table 1: 1.2 L/min there and back = the 1-way's 2.4 L/min), so the dose per cm is both passes' together
    scale = STD_UL_PER_CM / (len(trial.passes) * trial.flow_lps * 1e6 / (trial.speed_mps * 100.0))
    return {"canopy": 0.5 * float(leaf.mean()) * scale, "ground": float(dish.mean()) * scale,
            "canopy_top": 0.5 * float(leaf.reshape(3, 3, 3)[:, 2].mean()) * scale,
            "canopy_bottom": 0.5 * float(leaf.reshape(3, 3, 3)[:, 0].mean()) * scale,
            **{f"fraction_{k}": v for k, v in budget.fractions.items()}}


#: German basic drift values (Rautmann, Streloke & Winkler 2001, Mitt. Biol. Bundesanst. 383:133; the JKI table of
#: 90th percentiles, one application), % of the applied rate at 3, 5, 10, 15, 20 m: ground sprayers
RAUTMANN_2001 = {
    "vines, late": {3.0: 8.02, 5.0: 3.62, 10.0: 1.23, 15.0: 0.65, 20.0: 0.42},
    "vines, early": {3.0: 2.70, 5.0: 1.18, 10.0: 0.39, 15.0: 0.20, 20.0: 0.13},
    "fruit, late": {3.0: 15.73, 5.0: 8.41, 10.0: 3.60, 15.0: 1.81, 20.0: 1.09},
    "arable": {3.0: 0.95, 5.0: 0.57, 10.0: 0.29, 15.0: 0.20, 20.0: 0.15},
}


def drift_trial(conventional: bool, wind_mps: float = 3.0, seed: int = 0) -> Trial:
    """An ISO 22866 drift trial in a vineyard in full leaf: Biglia's vehicle and band nozzles (conventional HCI 60 03
    or air-inclusion HCA 60 03) spraying along all ten rows (2.5 m apart, 62 m), 3 m above the ground at 3 m/s,
    in a crosswind of ``wind_mps`` blowing out over the last row (x = 22.5 m), 20 °C, 60 %.

    The conditions of the drone drift trials this is compared with (Herbst et al. 2023; Bonds et al. 2024) were
    not readable beyond their abstracts: this set-up is the standard's, not theirs."""
    c = CONFIGS[9] if conventional else CONFIGS[11]  # T10 / T12: band nozzles at 3 m/s
    base = biglia_trial(c, seed)
    rows = vineyard_rows(10, SPACING_M, ROW_LENGTH_M)
    passes = [((r[0][0], -5.0), (r[0][0], ROW_LENGTH_M + 5.0)) if i % 2 == 0 else
              ((r[0][0], ROW_LENGTH_M + 5.0), (r[0][0], -5.0)) for i, r in enumerate(rows)]
    return Trial(vehicle=base.vehicle, rows=rows, passes=passes, height_m=base.height_m, speed_mps=base.speed_mps,
                 flow_lps=base.flow_lps, applied_lpha=base.applied_lpha, wind_enu=(wind_mps, 0.0, 0.0), hedge=HEDGE,
                 air=(20.0, 60.0), seed=seed)


# the drift trials docs/budget.md names as targets: their conditions as far as their abstracts and methods give them
# (their per-distance results were not reachable); Biglia's hollow cones stand in for nozzles whose spectra are not
# given (conventional HCI 60 03, VMD 145 µm; air inclusion HCA 60 03, VMD 597 µm)


def vineyard_bench_trial(conventional: bool, seed: int = 0) -> Trial:
    """Wang C., He X., Zeng A., Herbst A. et al. 2020 (Trans. CSAE; the companion of Wang C. et al. 2021, Sci. Total
    Environ. 777:146181): UAVs over an artificial vineyard test bench, height 1.5 m (taken above the hedges' top),
    2.0 m/s, crosswind 2.2-3.6 m/s (2.9 here), 29.8-34.3 °C (32), RH 10.7-30.6 % (20), Lechler IDK 120-015 and
    TR 80-0067 (the stand-ins above); the M600 Pro-class vehicle of :func:`biglia_trial`, one pass along the edge row."""
    base = drift_trial(conventional, 2.9, seed)
    x = base.rows[-1][0][0]
    return dataclasses.replace(base, passes=[((x, -5.0), (x, ROW_LENGTH_M + 5.0))], height_m=HEDGE[1] + 1.5,
                               speed_mps=2.0, applied_lpha=base.flow_lps * 1e4 / (2.0 * SPACING_M),
                               air=(32.0, 20.0))


def bench_trial_mg1p(conventional: bool, seed: int = 0) -> Trial:
    """Agronomy 2023, 13(1):270 (China Agricultural University): DJI MG-1P (8 rotors of 0.53 m, 10 kg net, 25 kg
    take-off at most: 19 kg here with its battery and half the 10 L tank), four nozzles under the lateral rotors
    1.46 m apart, TR 80-0067 at 0.30 L/min each or IDK 120-015 at 0.55 L/min (the stand-ins above), 2.0 m/s, 2 m
    working width, a drift test bench on open ground (no crop); height 2 m and a 3 m/s crosswind assumed (not read)."""
    c = CONFIGS[9] if conventional else CONFIGS[11]
    noz = tuple((0.0, y, -0.2) for y in (-0.73, -0.25, 0.25, 0.73))
    veh = TrialVehicle(mass_kg=19.0, n_rotors=8, prop_diameter_m=0.533, nozzles_flu=noz, cone_angle_deg=80.0,
                       vmd_um=c.dv[1], gsd=_gsd(c.dv), classes=7, rotor_plane_z=0.0, arm_m=0.73)
    flow = 4 * (0.30 if conventional else 0.55) / 60.0
    # no crop: two "rows" one working width apart mark the sprayed strip, the drift read from the flight line (x = 0)
    rows = vineyard_rows(2, 2.0, ROW_LENGTH_M, x0=-2.0)
    return Trial(vehicle=veh, rows=rows, passes=[((0.0, -5.0), (0.0, ROW_LENGTH_M + 5.0))], height_m=2.0, speed_mps=2.0,
                 flow_lps=flow, applied_lpha=flow * 1e4 / (2.0 * 2.0), wind_enu=(3.0, 0.0, 0.0), hedge=None,
                 air=(20.0, 60.0), seed=seed)
