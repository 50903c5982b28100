"""Which figures fit a run: each figure is drawn when the run did what it shows (a lift-off with liquid in the tank,
a flight through the air, a tank that was used, a wind that blew, several sorties, a deposition, segment rates
...); the others get one line saying why not.

:func:`run_profile` reads what decides it (a few time-series columns, the events, the files of the run
directory); :data:`FIT` maps each figure to its rule, a function of the :class:`RunProfile` returning None when
the figure fits, else the reason it is left out. SI units, world ENU.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["FIT", "RunProfile", "fitting_figures", "run_profile"]

#: the time-series columns the profile reads
PROFILE_COLUMNS = ("on_ground", "pos_enu_x_m", "pos_enu_y_m", "vel_enu_x_mps", "vel_enu_y_mps", "vel_enu_z_mps",
                   "wind_enu_x_mps", "wind_enu_y_mps", "wind_enu_z_mps", "tank_mass_kg", "tank_level_l",
                   "tank_flow_lps", "tank_flow_cmd_lps", "total_mass_kg", "battery_soc", "sortie", "rotor1_w_radps")
MOVED_M = 2.0  # horizontal extent of the path that makes a path figure worth it, m
WIND_MPS = 0.5  # a wind worth a figure, m/s
AIRSPEED_MPS = 0.5  # an airspeed whose drag is worth a figure, m/s
MASS_SHARE = 0.01  # a change of the total mass worth a figure
SOC_DROP = 0.25  # a battery drawn down this far is worth its figure on a single sortie


@dataclass(frozen=True)
class RunProfile:
    """What a run did, as the figures need to know it."""

    has_position: bool
    airborne: bool  # lifted off (for at least a second)
    tried_takeoff: bool  # ended unable to take off
    extent_m: float  # horizontal extent of the path
    wind_mps: float  # highest horizontal wind
    airspeed_mps: float  # highest speed through the air
    tank_liquid: bool  # the tank held liquid
    tank_used: bool  # liquid flowed (commanded or measured) or the level changed
    mass_share: float  # (max - min) / max of the total mass
    rotors: bool
    battery: bool
    soc_drop: float  # state of charge drawn, 0-1
    sorties: int
    services: int  # refills and battery swaps
    deposition: bool
    targeted_rows: bool
    budget: bool
    segment_rates: bool = False  # flew a canopy dose or a prescription map (an as-applied log)


def _span(a: np.ndarray | None) -> float:
    if a is None or not np.isfinite(a).any():
        return 0.0
    return float(np.nanmax(a) - np.nanmin(a))


def _peak(a: np.ndarray | None) -> float:
    return float(np.nanmax(np.abs(a))) if a is not None and np.isfinite(a).any() else 0.0


def run_profile(run_dir: str | Path) -> RunProfile:
    """The :class:`RunProfile` of a (validated) run directory."""
    import json

    from vinecli.report.figure_base import PlotData
    from vinecli.report.loader import load_run
    from vinecli.runs.as_applied_out import AS_APPLIED_JSON

    d = Path(run_dir)
    run = load_run(d)
    c = run.read_columns(PROFILE_COLUMNS)
    data = PlotData(cols=c, events=run.events(), summary=run.summary)
    g = lambda k: c.get(k) if data.has(k) else None  # noqa: E731 - a column with finite samples, else None
    x, y = g("pos_enu_x_m"), g("pos_enu_y_m")
    wind = np.hypot(c["wind_enu_x_mps"], c["wind_enu_y_mps"]) if data.has("wind_enu_x_mps", "wind_enu_y_mps") else None
    air = None
    if data.has("vel_enu_x_mps", "vel_enu_y_mps", "vel_enu_z_mps"):
        w = [c[f"wind_enu_{a}_mps"] if data.has(f"wind_enu_{a}_mps") else 0.0 for a in "xyz"]
        air = np.sqrt(sum((w[i] - c[f"vel_enu_{a}_mps"]) ** 2 for i, a in enumerate("xyz")))
    mass = g("total_mass_kg")
    dep = d / "deposition.json"
    rows = bool(json.loads(dep.read_text(encoding="utf-8")).get("rows")) if dep.is_file() else False
    soc = g("battery_soc")
    sortie = g("sortie")
    return RunProfile(
        has_position=x is not None and y is not None, airborne=data.liftoff() is not None,
        tried_takeoff=run.summary.get("status") == "cannot_take_off",
        extent_m=max(_span(x), _span(y)), wind_mps=_peak(wind), airspeed_mps=_peak(air),
        tank_liquid=_peak(g("tank_mass_kg")) > 0, tank_used=_peak(g("tank_flow_cmd_lps")) > 0 or
        _peak(g("tank_flow_lps")) > 0 or _span(g("tank_level_l")) > 1e-6,
        mass_share=_span(mass) / _peak(mass) if _peak(mass) > 0 else 0.0, rotors=data.has("rotor1_w_radps"),
        battery=soc is not None, soc_drop=_span(soc), sorties=int(np.nanmax(sortie)) if sortie is not None else 1,
        services=sum(e.get("kind") in ("refill", "battery_swap") for e in data.events),
        deposition=dep.is_file(), targeted_rows=rows, budget=(d / "budget.json").is_file(),
        segment_rates=(d / AS_APPLIED_JSON).is_file())


def _fig16(p: RunProfile) -> str | None:
    if not p.has_position or not p.airborne:
        return "the vehicle did not lift off (the map shows where it stood)"
    if p.extent_m < MOVED_M and p.wind_mps < WIND_MPS:
        return f"the vehicle went up and down within {p.extent_m:.1f} m, without wind (the map shows where)"
    return None


def _fig17(p: RunProfile) -> str | None:
    if not p.tank_liquid:
        return "no liquid in the tank"
    return None if p.airborne or p.tried_takeoff else "no lift-off"


def _fig18(p: RunProfile) -> str | None:
    if p.airspeed_mps < AIRSPEED_MPS:
        return f"the vehicle never moved through the air faster than {AIRSPEED_MPS} m/s: no drag to show"
    return None


def _fig19(p: RunProfile) -> str | None:
    return None if p.tank_used else "the tank was not used (no flow, the level did not change)"


def _fig20(p: RunProfile) -> str | None:
    if not p.rotors:
        return "no rotor speeds in this run"
    if p.mass_share >= MASS_SHARE or p.wind_mps >= WIND_MPS or p.tried_takeoff:
        return None
    return "neither the mass nor the wind changed: the rotor speeds only follow the flight"


def _fig21(p: RunProfile) -> str | None:
    if not p.airborne:
        return "the vehicle did not lift off"
    return None if p.wind_mps >= WIND_MPS else f"no wind (at most {p.wind_mps:.1f} m/s)"


def _fig22(p: RunProfile) -> str | None:
    if not p.battery:
        return "no battery model in this run"
    if p.sorties > 1 or p.services or p.soc_drop >= SOC_DROP:
        return None
    return f"one sortie, no battery swap, {100 * p.soc_drop:.0f} % of the charge drawn"


NO_SPRAY = "no deposition in this run (no sprayer used)"
NO_DOSE = "no segment rates in this run (no canopy dose or prescription map)"

#: figure id -> its rule: None when the figure fits the run, else why it is left out
FIT: dict[str, Callable[[RunProfile], str | None]] = {
    "fig16": _fig16, "fig17": _fig17, "fig18": _fig18, "fig19": _fig19, "fig20": _fig20, "fig21": _fig21,
    "fig22": _fig22,
    "fig23": lambda p: None if p.deposition else NO_SPRAY,
    "fig24": lambda p: None if p.targeted_rows else (NO_SPRAY if not p.deposition else "no targeted rows to chart"),
    "fig25": lambda p: None if p.budget else "no spray budget in this run (no sprayer used)",
    "fig26": lambda p: None if p.segment_rates else NO_DOSE,
    "fig27": lambda p: None if p.segment_rates else NO_DOSE,
}


def fitting_figures(p: RunProfile) -> dict[str, str | None]:
    """Figure id -> None (draw it) or the reason it is left out, for every figure of :data:`FIT`."""
    return {fid: rule(p) for fid, rule in FIT.items()}
