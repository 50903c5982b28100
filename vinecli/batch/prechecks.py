"""Checks a batch passes before any case runs: its inputs, its outputs, its memory.

* :func:`note_case_inputs`: every file the cases read (the vehicles the missions name, the worlds: built
  folders, or specs with the terrain and vehicle files they name) joins the batch's inputs
  (:mod:`vinecli.inputs`), next to the pipeline and the missions its loader read.
* :func:`check_case_targets`: every folder the batch will write (one per case, ``_worlds/<name>``) and
  ``batch.json`` may not be, contain or lie inside an input, pass through a symbolic link, or replace
  something vinecli did not make (a user's folder named like a case is named and kept); a case may not
  be named like a file the batch itself writes. Exit 2 before anything is written.
* :func:`check_cases_memory`: a case whose run could need more than a run may use
  (:func:`vinecli.sim.memory.check_run_memory`) stops the whole batch at load with exit 2.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from vinecli.batch.pipeline import Case
from vinecli.errors import InputError, OutputError
from vinecli.inputs import current_inputs, note_input
from vinecli.output_guard import contained_path, replaceable_problem
from vinecli.runs.batch_json import read_batch_json

__all__ = ["check_case_targets", "check_cases_memory", "note_case_inputs"]


def note_case_inputs(cases: Sequence[Case], pipeline: Path) -> None:
    """Read what the cases name (vehicles, worlds), so each is an input of the batch."""
    from vinecli.missions.spec_io import resolve_vehicle
    from vinecli.world.build import world_spec_inputs

    for v in dict.fromkeys(str(c.mission["vehicle"]) for c in cases if c.mission.get("vehicle")):
        resolve_vehicle(v, path=pipeline)
    for ref in dict.fromkeys(c.world for c in cases):
        p = Path(ref)
        if p.suffix in (".yaml", ".yml") and p.is_file():
            world_spec_inputs(p)
        else:
            note_input(p, "world")


def _refuse(target: Path, pipeline: Path, *, what: str) -> None:
    inputs = current_inputs()
    problem = inputs.conflict(target) if inputs is not None else None
    if problem is None and (target.exists() or target.is_symlink()):
        problem = replaceable_problem(target)
    if problem is not None:
        raise OutputError(f"{what} {target}: {problem}", path=pipeline)


def check_case_targets(cases: Sequence[Case], runs_dir: Path, pipeline: Path, *, batch_json: str,
                       worlds_dir: str, resume: bool = False) -> None:
    """OutputError/InputError (exit 2) naming the pipeline when a case or world folder, or ``batch_json``,
    must not be written (see the module docstring); ``worlds_dir``: where world specs are built. With
    ``resume`` the complete runs, which are kept as they are, are not targets."""
    from vinecli.runs.rundir import is_complete_run

    for c in cases:
        if c.name in (batch_json, worlds_dir):
            raise InputError(f"case name {c.name!r} is a name the batch writes itself ({batch_json}, {worlds_dir})",
                             path=pipeline)
        target = contained_path(runs_dir, c.name)
        if not (resume and is_complete_run(target)):
            _refuse(target, pipeline, what=f"case {c.name}:")
    for ref in dict.fromkeys(c.world for c in cases):
        if Path(ref).suffix in (".yaml", ".yml"):
            _refuse(contained_path(runs_dir, worlds_dir, Path(ref).stem), pipeline, what="world folder")
    bj = runs_dir / batch_json
    if bj.is_symlink() or (bj.exists() and not _is_batch_json(bj)):
        raise OutputError(f"{bj} is not a {batch_json} vinecli wrote (kept)", path=pipeline)
    inputs = current_inputs()
    problem = inputs.conflict(bj) if inputs is not None else None
    if problem is not None:
        raise OutputError(f"{bj}: {problem}", path=pipeline)


def _is_batch_json(path: Path) -> bool:
    try:
        return "pipeline" in read_batch_json(path)
    except InputError:
        return False


def check_cases_memory(cases: Sequence[Case], worlds: Mapping[str, str], pipeline: Path) -> None:
    """InputError (exit 2) for the first case that cannot fit (``worlds``: world reference -> built dir)."""
    from vinecli.missions.spec_io import resolve_vehicle
    from vinecli.sim.memory import check_run_memory
    from vinecli.specs.mission import MissionSpec
    from vinecli.world import load_world

    loaded: dict[str, Any] = {}
    for c in cases:
        wdir = worlds.get(c.world, c.world)
        if wdir not in loaded:
            try:
                loaded[wdir] = load_world(Path(wdir))
            except InputError:  # a broken world: its cases fail on their own, recorded in batch.json
                loaded[wdir] = None
        world = loaded[wdir]
        if world is None:
            continue
        mission = MissionSpec.model_validate(c.mission)
        vehicle = resolve_vehicle(mission.vehicle, path=pipeline) if mission.vehicle else world.vehicle
        try:
            check_run_memory(mission, vehicle, world)
        except InputError as exc:
            raise InputError(f"case {c.name}: {exc.problem}", path=pipeline) from None
