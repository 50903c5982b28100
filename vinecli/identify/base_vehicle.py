"""The base vehicle of a fit: where the parameters a log cannot identify come from."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vinecli.specs import deep_merge, read_yaml, resolve_base, validate_spec
from vinecli.specs.vehicle import VehicleSpec
from vinecli.vehicle import VEHICLES_DIR, known_vehicles, load_vehicle

__all__ = ["BaseVehicle", "fitted_spec", "load_base"]


@dataclass(frozen=True)
class BaseVehicle:
    """A base vehicle: what ``base:`` says in the fitted file (a shipped name or an absolute path), its spec
    and its resolved mapping."""

    ref: str
    spec: VehicleSpec
    data: dict[str, Any]


def load_base(name_or_path: str | Path) -> BaseVehicle:
    """A shipped vehicle by name or a vehicle file (SpecError, exit 2, when unknown or invalid)."""
    s = str(name_or_path)
    if s in known_vehicles():
        path, ref = VEHICLES_DIR / f"{s}.yaml", s
    else:
        path = Path(s).resolve()
        ref = str(path)
    spec = load_vehicle(path if path.is_file() else s)
    return BaseVehicle(ref, spec, resolve_base(path, read_yaml(path), search=(VEHICLES_DIR,)))


def fitted_spec(base: BaseVehicle, doc: dict[str, Any], where: str) -> VehicleSpec:
    """The fitted vehicle ``doc`` (``vehicle.yaml``'s mapping) merged over ``base`` and validated."""
    return validate_spec(VehicleSpec, deep_merge(base.data, {k: v for k, v in doc.items() if k != "base"}), where)
