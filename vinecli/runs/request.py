"""What one run is asked to do: :class:`RunRequest`, built once by ``vinecli run mission`` from its command line or
by a batch for each of its cases, and read by :func:`vinecli.runs.mission.run_mission` from the mission file down to
the run folder. Plain, frozen and picklable (a batch sends it to its workers)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from vinecli.sitl.options import PX4_DEFAULTS, AutopilotOptions

if TYPE_CHECKING:
    from vinecli.missions.spec_io import MissionFile
    from vinecli.specs.mission import MissionSpec

__all__ = ["RunRequest"]


@dataclass(frozen=True)
class RunRequest:
    """One run: the mission flown, the world it is flown in, where its folder goes, and its options."""

    #: a mission YAML path, a validated MissionSpec or a MissionFile (:func:`~vinecli.missions.spec_io.read_mission`:
    #: the file and its vehicle already read)
    mission: str | Path | MissionSpec | MissionFile
    world_dir: str | Path  # a built world directory (``vinecli world build``)
    runs_dir: str | Path  # the run folder is ``runs_dir/<run_id>/``
    seed: int = 0  # sensor noise, turbulence
    run_id: str | None = None  # None: ``<mission name>-s<seed>``
    case: str | None = None  # the batch case the run is (summary.json ``case``; None: the run id)
    autopilot: str | None = None  # None: the mission's ``autopilot``
    truth: bool | None = None  # None: the mission's ``truth`` (controllers fly on ground truth)
    record_rate: float | None = None  # time-series rows per second, Hz; None: the mission's ``record_rate_hz``
    mcap: bool = False  # also write ``run.mcap`` (Foxglove)
    wall_timeout_s: float | None = None  # stop the run (status interrupted) after this wall-clock time, s
    #: replace an existing run folder made by vinecli (otherwise OutputError, exit 2, before simulating; a folder
    #: vinecli did not make, or holding files it did not write, is never replaced)
    overwrite: bool = False
    #: more inputs the run folder may not be, contain or lie inside (the mission file, its ``base:`` chain, the
    #: vehicle and the world always)
    protect: Sequence[str | Path] = ()
    autopilot_options: AutopilotOptions = PX4_DEFAULTS  # PX4 / ArduPilot / MAVLink options of the autopilot
