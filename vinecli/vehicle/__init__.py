"""Vehicles: load ``vehicles/*.yaml`` specs (here) and turn them into URDF for PyBullet (:mod:`~vinecli.vehicle.urdf`).

May import the ground floor and :mod:`vinecli.specs`."""

from __future__ import annotations

from pathlib import Path

import vinecli
from vinecli.errors import SpecError
from vinecli.specs import load_spec
from vinecli.specs.vehicle import VehicleSpec

__all__ = ["VEHICLES_DIR", "known_vehicles", "load_vehicle", "total_mass"]

#: ``vehicles/`` of the repository (repo root = parent of the ``vinecli`` package).
VEHICLES_DIR = Path(vinecli.__file__).resolve().parents[1] / "vehicles"


def known_vehicles() -> list[str]:
    """Names of the vehicles shipped in ``vehicles/``."""
    return sorted(p.stem for p in VEHICLES_DIR.glob("*.yaml")) if VEHICLES_DIR.is_dir() else []


def load_vehicle(name_or_path: str | Path) -> VehicleSpec:
    """A vehicle by name (``vehicles/<name>.yaml`` of the repo) or by path to a YAML file.

    Unknown names raise :class:`~vinecli.errors.SpecError` listing the known names. A file's ``base:`` is
    looked up next to it, then among the shipped vehicles (a fitted vehicle's ``base: x500``).
    """
    s = str(name_or_path)
    p = Path(s)
    if p.suffix in (".yaml", ".yml") or p.is_file() or "/" in s:
        if not p.is_file():
            raise SpecError("vehicle file not found", path=p)
        return load_spec(p, VehicleSpec, base_dirs=(VEHICLES_DIR,))
    candidate = VEHICLES_DIR / f"{s}.yaml"
    if not candidate.is_file():
        raise SpecError(f"unknown vehicle {s!r}; known: {', '.join(known_vehicles()) or '(none)'}", path=VEHICLES_DIR)
    return load_spec(candidate, VehicleSpec)


def total_mass(vehicle: VehicleSpec, fill_l: float) -> float:
    """Rigid mass (frame + rotors + payload) plus liquid, kg."""
    return vehicle.dry_mass() + vehicle.liquid_mass(fill_l)
