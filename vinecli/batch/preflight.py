"""Checks a batch passes before any case runs (issue 20): every case fits in memory.

A case whose run could need more than a run may use (:func:`vinecli.sim.memory.check_run_memory`) stops
the whole batch at load with exit 2, naming the pipeline and the case, instead of failing (or taking the
machine's memory) once its worker gets to it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from vinecli.batch.spec import Case
from vinecli.errors import InputError

__all__ = ["check_cases_memory"]


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
            loaded[wdir] = load_world(Path(wdir))
        world = loaded[wdir]
        mission = MissionSpec.model_validate(c.mission)
        vehicle = resolve_vehicle(mission.vehicle, path=pipeline) if mission.vehicle else world.vehicle
        try:
            check_run_memory(mission, vehicle, world)
        except InputError as exc:
            raise InputError(f"case {c.name}: {exc.problem}", path=pipeline) from None
