"""Loading mission files (``pipelines/missions/*.yaml`` or any path) into :class:`MissionSpec`.

Errors are :class:`~vinecli.errors.SpecError` lines naming the file and the field. A
``vehicle:`` given as a name or path is loaded through :func:`vinecli.vehicle.load_vehicle`
so a typo fails before any simulation starts; :func:`read_mission` keeps what it loaded
(:class:`MissionFile`), so a run reads the file and loads the vehicle once.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from vinecli.errors import SpecError
from vinecli.missions.quantities import check_quantities
from vinecli.outputs import write_text_atomic
from vinecli.specs import YAML_DUMPER, read_yaml, resolve_base, validate_spec
from vinecli.specs.mission import MissionSpec
from vinecli.specs.vehicle import VehicleSpec

log = logging.getLogger(__name__)


def mission_from_dict(data: dict[str, Any], path: Path | str) -> MissionSpec:
    """Validate a mission mapping (``base:`` already resolved); SpecError names ``path`` and the field."""
    mission = validate_spec(MissionSpec, data, path)
    _check_windows_syntax(mission, path)
    check_quantities(mission.checks, path)
    return mission


@dataclass(frozen=True)
class MissionFile:
    """A mission read once: the validated spec, the file it came from (None: a spec made in memory) and the
    vehicle it names, loaded (None: the mission flies the world's vehicle)."""

    spec: MissionSpec
    path: Path | None = None
    vehicle: VehicleSpec | None = None


def load_mission(path: Path | str, *, check_vehicle: bool = True) -> MissionSpec:
    """Read, resolve ``base:`` and validate a mission YAML file.

    ``vehicle`` names are resolved relative to the mission file first (a path), then through
    :func:`vinecli.vehicle.load_vehicle` (``vehicles/<name>.yaml``); ``check_vehicle=False`` skips that.
    """
    if check_vehicle:
        return read_mission(path).spec
    path = Path(path)
    return mission_from_dict(resolve_base(path.resolve(), read_yaml(path)), path)


def read_mission(mission: Path | str | MissionSpec | MissionFile) -> MissionFile:
    """The mission and the vehicle it names, each read once (a :class:`MissionFile` is returned as it is).

    A path is parsed and validated as :func:`load_mission` does, its ``vehicle`` resolved relative to the
    file first; a :class:`MissionSpec` keeps its ``vehicle`` as given (a name or a path from the working
    directory). SpecError names the file (or the mission) and the field.
    """
    if isinstance(mission, MissionFile):
        return mission
    if isinstance(mission, MissionSpec):
        veh = resolve_vehicle(mission.vehicle, path=mission.name) if mission.vehicle is not None else None
        return MissionFile(mission, None, veh)
    path = Path(mission)
    spec = mission_from_dict(resolve_base(path.resolve(), read_yaml(path)), path)
    veh = resolve_vehicle(spec.vehicle, relative_to=path.parent, path=path) if spec.vehicle is not None else None
    return MissionFile(resolve_map_paths(spec, path.parent), path, veh)


def resolve_map_paths(spec: MissionSpec, folder: Path) -> MissionSpec:
    """``spec`` with its spray phases' prescription paths resolved relative to the mission file's ``folder``."""
    phases = list(spec.phases)
    for i, p in enumerate(phases):
        pr = getattr(p, "prescription", None)
        if pr is not None and not Path(pr.path).is_absolute():
            phases[i] = p.model_copy(update={"prescription": pr.model_copy(update={"path": str(folder / pr.path)})})
    return spec.model_copy(update={"phases": phases})


def resolve_vehicle(name_or_path: str, *, relative_to: Path | None = None, path: Path | str | None = None) -> VehicleSpec:
    """Load the vehicle a mission names; SpecError ``path: vehicle: ...`` if it cannot be found.

    With ``relative_to`` (the folder of the mission file ``path``) a vehicle file is a reference from that
    file: resolved relative to it and confined (:func:`vinecli.specs.refs.spec_reference`); a name is one of
    vinecli's vehicles."""
    from vinecli.specs.refs import SPEC_SUFFIXES, spec_reference

    if relative_to is not None and (name_or_path.endswith(SPEC_SUFFIXES) or "/" in name_or_path):
        naming = Path(path) if path is not None else relative_to / "mission.yaml"
        name_or_path = str(spec_reference(name_or_path, naming, "vehicle"))
    from vinecli.vehicle import load_vehicle

    try:
        return load_vehicle(name_or_path)
    except SpecError as exc:
        raise SpecError(f"vehicle: {exc}", path=path) from None


def _check_windows_syntax(mission: MissionSpec, path: Path | str) -> None:
    """Reject malformed window/time strings of checks at load time (exit 2, not a failed check)."""
    from vinecli.missions.rundata import parse_time_ref

    for i, c in enumerate(mission.checks):
        refs: list[tuple[str, object]] = []
        if c.window is not None:
            refs += [("window", c.window[0]), ("window", c.window[1])]
        if c.at is not None:
            refs.append(("at", c.at))
        for field, ref in refs:
            if isinstance(ref, str):
                try:
                    parse_time_ref(ref)
                except ValueError as exc:
                    raise SpecError(f"checks.{i}.{field}: {exc}", path=path) from None
        if c.reduce == "at" and c.at is None and c.quantity != "status" and not c.quantity.startswith("metric:"):
            raise SpecError(f"checks.{i}.at: reduce 'at' needs an 'at' time", path=path)
        if c.op == "between" and not (isinstance(c.bound, (list, tuple)) and len(c.bound) == 2):
            raise SpecError(f"checks.{i}.bound: op 'between' needs [lo, hi]", path=path)
        if c.op == "within_pct" and c.reference is None:
            raise SpecError(f"checks.{i}.reference: op 'within_pct' needs a reference value or metric", path=path)
        if c.quantity == "status" and c.op not in ("==", "!="):
            raise SpecError(f"checks.{i}.op: quantity 'status' supports only == and !=", path=path)


def dump_mission(mission: MissionSpec) -> str:
    """The mission as YAML text (resolved, every default written out)."""
    return yaml.dump(mission.model_dump(mode="json"), Dumper=YAML_DUMPER, sort_keys=False)


def write_mission(path: Path | str, mission: MissionSpec) -> None:
    """Write a mission YAML atomically (temporary file, then rename)."""
    write_text_atomic(path, dump_mission(mission))
