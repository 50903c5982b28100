"""Spray patterns over vine rows (compatibility layer over the row tools).

* :func:`boustrophedon`: rows (ENU polylines) -> passes in the operator order of
  :func:`vinecli.rows.plan.plan_rows` (nearest row first, alternating directions).
* :func:`spray_mission`: rows -> a MissionSpec (takeoff, spray, land) to export as ``.plan``.
* Row detection lives in :mod:`vinecli.rows.detect` (the detector) and
  :mod:`vinecli.rows.source` (DSM / world sources); the names are re-exported here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from pydantic import ValidationError

from vinecli.errors import InputError
from vinecli.rows.detect import Polyline, RowDetection, detect_rows_grid
from vinecli.rows.plan import plan_rows
from vinecli.rows.source import DsmRows, detect_rows_in_dsm, detect_rows_on_grid
from vinecli.specs import format_validation_error
from vinecli.specs.limits import MAX_DURATION_S
from vinecli.specs.mission import LandPhase, MissionSpec, SprayPhase, TakeoffPhase
from vinecli.spray_defaults import SPRAY_DEFAULTS

__all__ = ["DsmRows", "Polyline", "RowDetection", "boustrophedon", "detect_rows_grid", "detect_rows_in_dsm",
           "detect_rows_on_grid", "spray_mission"]


def boustrophedon(rows: Sequence[Sequence[tuple[float, float]]], start_xy: tuple[float, float] = (0.0, 0.0)
                  ) -> list[Polyline]:
    """The rows as passes in flight order (see :func:`plan_rows`): the row nearest ``start_xy`` first,
    entered at its nearer end, each next row entered at the end nearest the last exit."""
    plan = plan_rows(rows, start_xy, speed_mps=1.0, accel_mps2=1.0)
    return [leg.points for leg in plan.legs if leg.spray]


def spray_mission(rows: Sequence[Sequence[tuple[float, float]]], *, name: str = "spray-rows",
                  height_m: float = SPRAY_DEFAULTS.height_m, speed_mps: float = SPRAY_DEFAULTS.speed_mps,
                  flow_lps: float = SPRAY_DEFAULTS.flow_lps, takeoff_m: float = SPRAY_DEFAULTS.takeoff_m,
                  estimated_s: float | None = None, dose: dict[str, Any] | None = None) -> MissionSpec:
    """Takeoff, one spray phase over ``rows`` (explicit polylines, flown as :func:`plan_rows` orders
    them), land. ``max_duration_s`` = 1.5 x ``estimated_s`` + 60 s when given (capped at the spec limit).
    ``dose``: spray phase fields given instead of ``flow_lps`` (a rate, a canopy dose, a prescription map; their
    ``rows`` replace ``rows``).

    InputError (exit 2) for values the mission spec refuses (e.g. a speed beyond :mod:`vinecli.specs.limits`).
    """
    rows_l = [[(round(float(x), 3), round(float(y), 3)) for x, y in r] for r in rows]
    length = sum(math.dist(a, b) for r in rows_l for a, b in zip(r[:-1], r[1:], strict=True))
    budget = 1.5 * estimated_s + 60.0 if estimated_s else 2.0 * length / speed_mps + 20.0 * len(rows_l) + 120.0
    try:
        spray: dict[str, Any] = {"rows": rows_l, "height_agl_m": height_m, "speed_mps": speed_mps,
                                 **({"flow_lps": flow_lps} if dose is None else dose)}
        what = f"{flow_lps:g} L/s" if dose is None else ", ".join(f"{k} {v}" for k, v in dose.items()
                                                                 if k in ("rate_lpha", "lwa_dose_l", "trv_dose_l"))
        return MissionSpec(
            name=name,
            description=f"boustrophedon spray over {len(rows_l)} rows at {height_m:g} m, {what or 'a prescription map'}",
            phases=[TakeoffPhase(altitude_agl_m=takeoff_m), SprayPhase(**spray), LandPhase()],
            max_duration_s=min(MAX_DURATION_S, round(budget, 1)),
        )
    except ValidationError as exc:
        raise InputError(f"spray mission: {format_validation_error(exc)}") from None
