"""Defaults of a spray plan over vine rows, declared once (the spray phase of a mission spec,
:func:`vinecli.missions.patterns.spray_mission`,
:func:`vinecli.missions.rowjob.plan_rows_job`, ``vinecli plan rows``). Plain Python, light to import: the
command line reads them for its option defaults."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SprayDefaults:
    """Spray height, speed, flow and take-off altitude of a row plan when not given."""

    height_m: float = 2.0  # spray height above the canopy surface, m
    speed_mps: float = 1.5  # ground speed along the rows, m/s
    flow_lps: float = 0.05  # nozzle flow on the rows, L/s
    takeoff_m: float = 3.0  # take-off altitude above home, m


SPRAY_DEFAULTS = SprayDefaults()
