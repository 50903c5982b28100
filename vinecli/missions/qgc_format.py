"""The QGroundControl ``.plan`` file format (JSON): the model of the fields vinecli uses, reading (validated,
SpecError naming the file and field) and writing (atomic). Items <-> phases: :mod:`vinecli.missions.qgc_import`,
:mod:`vinecli.missions.qgc_export` (through :mod:`vinecli.phase_items`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from vinecli.errors import InputError, SpecError
from vinecli.inputs import read_input_json
from vinecli.outputs import write_text_atomic
from vinecli.specs import format_validation_error
from vinecli.specs.limits import MAX_FENCE_VERTICES, MAX_PLAN_BYTES, MAX_PLAN_ITEMS, over_limit
from vinecli.specs.vehicle import VehicleSpec

#: the flow (L/s) an actuator value of 1.0 stands for when the vehicle has no tank
DEFAULT_NOZZLE_MAX_FLOW_LPS = 0.1


class _Loose(BaseModel):
    model_config = ConfigDict(extra="allow")


class SimpleItem(_Loose):
    type: Literal["SimpleItem"] = "SimpleItem"
    command: int
    frame: int = 3  # MAV_FRAME_GLOBAL_RELATIVE_ALT
    params: list[float | None] = Field(min_length=7, max_length=7)
    autoContinue: bool = True
    doJumpId: int | None = None

    def p(self, i: int) -> float:
        """Param i (1-based, 1..7); JSON null -> NaN."""
        v = self.params[i - 1]
        return math.nan if v is None else float(v)


class TransectStyle(_Loose):
    Items: list[SimpleItem] = Field(default_factory=list)


class ComplexItem(_Loose):
    type: Literal["ComplexItem"] = "ComplexItem"
    complexItemType: str
    TransectStyleComplexItem: TransectStyle | None = None


class PlanMission(_Loose):
    version: int = 2
    firmwareType: int = 12
    vehicleType: int = 2
    hoverSpeed: float = 5.0
    cruiseSpeed: float = 15.0
    plannedHomePosition: list[float] = Field(min_length=3, max_length=3)
    items: list[SimpleItem | ComplexItem] = Field(min_length=1)


class FenceCircle(_Loose):
    center: list[float] = Field(min_length=2, max_length=2)
    radius: float = Field(gt=0)


class FencePolygon(_Loose):
    polygon: list[list[float]] = Field(min_length=3)
    inclusion: bool = True
    version: int = 1


class FenceCircleItem(_Loose):
    circle: FenceCircle
    inclusion: bool = True
    version: int = 1


class GeoFence(_Loose):
    version: int = 2
    polygons: list[FencePolygon] = Field(default_factory=list)
    circles: list[FenceCircleItem] = Field(default_factory=list)


class Plan(_Loose):
    fileType: Literal["Plan"]
    version: int = 1
    groundStation: str = "QGroundControl"
    mission: PlanMission
    geoFence: GeoFence | None = None
    rallyPoints: dict[str, Any] | None = None


def read_plan(path: Path | str) -> Plan:
    """Parse and validate a .plan file; SpecError naming the file and field. Sizes no real plan reaches are refused
    before the file is validated (:data:`~vinecli.specs.limits.MAX_PLAN_BYTES`, ``MAX_PLAN_ITEMS``, a fence
    polygon's ``MAX_FENCE_VERTICES``)."""
    path = Path(path)
    try:
        data = read_input_json(path, ".plan", max_bytes=MAX_PLAN_BYTES)
    except InputError as exc:
        raise SpecError(exc.problem, path=path) from None
    problem = _size_problem(data)
    if problem:
        raise SpecError(problem, path=path)
    try:
        return Plan.model_validate(data)
    except ValidationError as exc:
        raise SpecError(format_validation_error(exc), path=path) from None


def _size_problem(data: Any) -> str | None:
    """What makes a parsed .plan larger than any real one (items, transect items, fence vertices), or None."""
    mission = data.get("mission") if isinstance(data, dict) else None
    items = mission.get("items") if isinstance(mission, dict) else None
    if isinstance(items, list):
        n = len(items) + sum(len(it.get("TransectStyleComplexItem", {}).get("Items") or [])
                             for it in items if isinstance(it, dict) and isinstance(it.get("TransectStyleComplexItem"), dict))
        problem = over_limit("mission items", n, MAX_PLAN_ITEMS, "split the job into several plans")
        if problem:
            return f"mission.items: {problem}"
    fence = data.get("geoFence") if isinstance(data, dict) else None
    for k, poly in enumerate(fence.get("polygons") or [] if isinstance(fence, dict) else []):
        if isinstance(poly, dict) and isinstance(poly.get("polygon"), list):
            problem = over_limit("fence vertices", len(poly["polygon"]), MAX_FENCE_VERTICES, "simplify the fence")
            if problem:
                return f"geoFence.polygons[{k}]: {problem}"
    return None


def vehicle_nozzle_flow_lps(vehicle: VehicleSpec) -> float:
    """The flow (L/s) a .plan's actuator value 1.0 stands for on ``vehicle``: its nozzle's maximum
    (:data:`DEFAULT_NOZZLE_MAX_FLOW_LPS` without a tank)."""
    return vehicle.tank.nozzle_max_flow_lps if vehicle.tank is not None else DEFAULT_NOZZLE_MAX_FLOW_LPS


def write_plan(path: Path | str, plan: dict[str, Any], *, overwrite: bool = True) -> None:
    """Write a .plan atomically (temporary file, then rename; without ``overwrite`` never over another writer's)."""
    write_text_atomic(path, json.dumps(plan, indent=4) + "\n", overwrite=overwrite)
