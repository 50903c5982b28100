"""Pipeline files (``pipelines/*.yaml``): missions and sweeps -> a list of cases.

Example::

    name: ci
    world: ../worlds/vineyard-sample.yaml    # world spec (built once into RUNS/_worlds/<name>/) or a built world dir
    seed: 0                                  # root seed; per-case seeds come from numpy SeedSequence
    timeout_s: 900                           # wall-clock limit per case
    missions:
      - missions/takeoff.yaml                # case "takeoff"
      - {mission: missions/gust.yaml, name: gust-strong, set: {wind.law.amplitude_mps: 4.0}}
    sweep:
      mission: missions/gust.yaml
      matrix:                                # cartesian product over dotted paths of the mission
        wind.law.amplitude_mps: [1.0, 2.0]
        tank_fill_l: [0.5, 1.0]
        vehicle: [x500-sprayer, hex-sprayer]
      seeds: 2                               # replicates (or a 'seed' axis with explicit seeds)

Paths are relative to the pipeline file. Case names are stable: a plain mission entry is
named after the mission (or ``name``); a sweep case is ``<mission>-<8-hex hash of its
parameters>-s<seed>``. Seeds not given explicitly are
``SeedSequence(root, spawn_key=(crc32(case key), replicate)).generate_state(1)[0]``, so they do
not change when cases are added, removed or reordered.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field, field_validator, model_validator

from vinecli.constants import MAX_SEED
from vinecli.errors import SpecError
from vinecli.missions.spec_io import mission_from_dict, resolve_map_paths
from vinecli.names import SafeName, check_name
from vinecli.specs import StrictModel, load_spec, read_yaml, resolve_base
from vinecli.specs.limits import MAX_DURATION_S, MAX_RATE_HZ, SeedInt
from vinecli.specs.refs import SPEC_SUFFIXES, spec_reference

#: most cases one pipeline may expand to
MAX_CASES = 100_000


class MissionEntry(StrictModel):
    """One mission of a pipeline, optionally with overrides and replicates."""

    mission: str = Field(description="mission YAML, relative to the pipeline file")
    name: SafeName | None = Field(None, description="case name (default: the mission's name)")
    world: str | None = Field(None, description="world spec or built world dir for this case (default: the pipeline's)")
    seed: SeedInt | None = Field(None, description="explicit seed (default: derived from the root seed)")
    seeds: int = Field(1, ge=1, le=MAX_CASES, description="number of replicates with derived seeds")
    set: dict[str, Any] = Field(default_factory=dict, description="dotted-path overrides of the mission")


class SweepSpec(StrictModel):
    """Cartesian product over dotted paths of one mission (``world`` and ``seed`` are special axes)."""

    mission: str
    name: SafeName | None = Field(None, description="case name prefix (default: the mission's name)")
    world: str | None = None
    matrix: dict[str, list[Any]] = Field(min_length=1)
    seeds: int = Field(1, ge=1, le=MAX_CASES, description="replicates per grid point when 'seed' is not an axis")
    set: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _non_empty_axes(self) -> SweepSpec:
        for k, v in self.matrix.items():
            if not v:
                raise ValueError(f"matrix axis {k!r} has no values")
        return self


class PipelineSpec(StrictModel):
    """A batch of cases: missions and/or sweeps, on a shared world or one per case."""

    name: SafeName
    description: str = ""
    world: str | None = Field(None, description="default world: a world spec (worlds/*.yaml) or a built world dir")
    seed: SeedInt = Field(0, description="root seed")
    autopilot: str | None = Field(None, description="override every mission's autopilot")
    px4_bin: str | None = Field(None, description="PX4 SITL binary (relative to the pipeline file): every PX4 case "
                                "starts its own PX4 process on a free instance")
    ardupilot_bin: str | None = Field(None, description="ArduCopter SITL binary (relative to the pipeline file): every "
                                      "ArduPilot case starts its own ArduPilot process on a free instance")
    truth: bool | None = None
    record_rate_hz: float | None = Field(None, gt=0, le=MAX_RATE_HZ)
    timeout_s: float | None = Field(900.0, gt=0, le=MAX_DURATION_S, description="wall-clock limit per case, s")
    missions: list[MissionEntry] = Field(default_factory=list, description="mission paths or MissionEntry mappings")
    sweep: SweepSpec | list[SweepSpec] | None = None

    @field_validator("missions", mode="before")
    @classmethod
    def _paths_to_entries(cls, v: Any) -> Any:
        if isinstance(v, list):
            return [{"mission": x} if isinstance(x, str) else x for x in v]
        return v

    @model_validator(mode="after")
    def _something(self) -> PipelineSpec:
        if not self.missions and not self.sweep:
            raise ValueError("a pipeline needs 'missions' and/or 'sweep'")
        return self

    def sweeps(self) -> list[SweepSpec]:
        if self.sweep is None:
            return []
        return self.sweep if isinstance(self.sweep, list) else [self.sweep]


def count_cases(pipeline: PipelineSpec) -> int:
    """How many cases ``pipeline`` expands to (computed without expanding)."""
    n = sum(e.seeds for e in pipeline.missions)
    for sw in pipeline.sweeps():
        grid = math.prod(len(v) for k, v in sw.matrix.items())
        n += grid * (1 if "seed" in sw.matrix else sw.seeds)
    return n


@dataclass(frozen=True)
class Case:
    """One expanded case: a validated mission mapping, its world reference and its seed."""

    name: str
    mission: dict[str, Any]  # validated MissionSpec as JSON-able dict (overrides applied)
    mission_path: str
    world: str  # absolute path: world spec file or built world dir
    seed: int
    params: dict[str, Any]


def load_pipeline(path: Path | str) -> PipelineSpec:
    """Read and validate a pipeline YAML file (SpecError names the file and field)."""
    return load_spec(path, PipelineSpec)


def with_world(pipeline: PipelineSpec, world: str | Path) -> PipelineSpec:
    """``pipeline`` with ``world`` (a built world dir or a world spec, made absolute) as its default world
    (``run batch --world``; entries naming their own world keep it)."""
    return pipeline.model_copy(update={"world": str(Path(world).resolve())})


def pipeline_cases(path: Path | str, world: str | Path | None = None) -> list[Case]:
    """The cases ``vinecli run batch PIPELINE [--world W]`` runs, expanded and validated (SpecError naming the
    pipeline for a bad entry, mission or world)."""
    spec = load_pipeline(path)
    return expand_cases(with_world(spec, world) if world is not None else spec, path)


def derive_seed(root: int, key: str, replicate: int = 0) -> int:
    """Stable 31-bit seed for a case key (numpy SeedSequence)."""
    ss = np.random.SeedSequence(root, spawn_key=(zlib.crc32(key.encode()), replicate))
    return int(ss.generate_state(1, dtype=np.uint32)[0] & 0x7FFFFFFF)


def params_hash(params: dict[str, Any]) -> str:
    """8-hex hash of a parameter mapping (sorted JSON)."""
    return hashlib.sha1(json.dumps(params, sort_keys=True, default=str).encode()).hexdigest()[:8]


def set_dotted(data: dict[str, Any], dotted: str, value: Any) -> None:
    """Set ``a.b.c`` in nested mappings (creating mappings; list indices as integers)."""
    parts = dotted.split(".")
    cur: Any = data
    for i, p in enumerate(parts[:-1]):
        nxt_is_index = parts[i + 1].isdigit()
        if isinstance(cur, list):
            cur = cur[int(p)]
            continue
        if cur.get(p) is None:
            cur[p] = [] if nxt_is_index else {}
        cur = cur[p]
    last = parts[-1]
    if isinstance(cur, list):
        cur[int(last)] = value
    else:
        cur[last] = value


def _read_mission(ref: str, pipeline_path: Path, where: str) -> tuple[Path, dict[str, Any]]:
    """The mission file a pipeline entry names (confined, :func:`vinecli.specs.refs.spec_reference`), read."""
    path = spec_reference(ref, pipeline_path, where)
    return path, resolve_base(path, read_yaml(path))


def _abs_vehicle(data: dict[str, Any], mission_path: Path) -> None:
    """A vehicle file the mission names, made absolute (confined to where the mission may refer to)."""
    v = data.get("vehicle")
    if isinstance(v, str) and (v.endswith(SPEC_SUFFIXES) or "/" in v):
        data["vehicle"] = str(spec_reference(v, mission_path, "vehicle"))


def _seed(value: Any, pipeline_path: Path, where: str) -> int:
    """A seed from the pipeline: an integer in [0, MAX_SEED] (SpecError otherwise: no folding, no collisions)."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_SEED:
        raise SpecError(f"{where}: a seed is an integer in [0, {MAX_SEED}], got {value!r}", path=pipeline_path)
    return value


def _resolve_world(ref: Any, base: Path, pipeline_path: Path, where: str) -> str:
    """A pipeline's world: a built world folder, or a world spec (confined like every spec reference)."""
    if ref is None:
        raise SpecError(f"{where}: no world (set 'world' in the pipeline or the entry)", path=pipeline_path)
    if not isinstance(ref, str) or not ref:
        raise SpecError(f"{where}: world: expected a path, got {type(ref).__name__}", path=pipeline_path)
    if ref.endswith(SPEC_SUFFIXES):
        return str(spec_reference(ref, pipeline_path, f"{where}.world"))
    p = Path(ref)
    if not p.is_absolute():
        p = base / p
    if not p.exists():
        raise SpecError(f"{where}: world not found: {ref}", path=pipeline_path)
    return str(p.resolve())


def expand_cases(pipeline: PipelineSpec, pipeline_path: Path | str) -> list[Case]:
    """All cases of a pipeline, validated (SpecError names the pipeline file and the case)."""
    pipeline_path = Path(pipeline_path)
    base = pipeline_path.resolve().parent
    n_cases = count_cases(pipeline)
    if n_cases > MAX_CASES:
        raise SpecError(f"the pipeline expands to {n_cases:,} cases (at most {MAX_CASES:,})", path=pipeline_path)
    cases: list[Case] = []

    def make(name: str, mpath: Path, raw: dict[str, Any], overrides: dict[str, Any], world: str, seed: int,
             params: dict[str, Any]) -> Case:
        data = copy.deepcopy(raw)
        for k, v in overrides.items():
            try:
                set_dotted(data, k, v)
            except (KeyError, IndexError, TypeError, ValueError) as exc:
                raise SpecError(f"case {name}: cannot set {k!r}: {exc}", path=pipeline_path) from None
        if pipeline.autopilot is not None:
            data["autopilot"] = pipeline.autopilot
        if pipeline.truth is not None:
            data["truth"] = pipeline.truth
        if pipeline.record_rate_hz is not None:
            data["record_rate_hz"] = pipeline.record_rate_hz
        _abs_vehicle(data, mpath)
        try:
            spec = resolve_map_paths(mission_from_dict(data, mpath), mpath.parent)  # prescriptions beside it
        except SpecError as exc:
            raise SpecError(f"case {name}: {exc}", path=pipeline_path) from None
        return Case(name, spec.model_dump(mode="json"), str(mpath.resolve()), world, seed, params)

    for i, entry in enumerate(pipeline.missions):
        e = entry
        mpath, raw = _read_mission(e.mission, pipeline_path, f"missions.{i}.mission")
        name = e.name or str(raw.get("name") or mpath.stem)
        world = _resolve_world(e.world or pipeline.world, base, pipeline_path, f"missions.{i}")
        for r in range(e.seeds):
            if e.seed is not None and e.seeds == 1:
                seed = e.seed
            else:
                seed = derive_seed(pipeline.seed, name, r) if e.seed is None else _seed(e.seed + r, pipeline_path,
                                                                                       f"missions.{i}.seed")
            cname = name if e.seeds == 1 else f"{name}-s{seed}"
            cases.append(make(cname, mpath, raw, e.set, world, seed, {"set": e.set}))

    for j, sw in enumerate(pipeline.sweeps()):
        mpath, raw = _read_mission(sw.mission, pipeline_path, f"sweep.{j}.mission")
        prefix = sw.name or str(raw.get("name") or mpath.stem)
        axes = list(sw.matrix)
        for combo in itertools.product(*(sw.matrix[a] for a in axes)):
            point = dict(zip(axes, combo, strict=True))
            world_ref = point.pop("world", None) or sw.world or pipeline.world
            world = _resolve_world(world_ref, base, pipeline_path, f"sweep.{j}")
            explicit_seed = point.pop("seed", None)
            key_params = {**point, "world": str(world_ref)} if "world" in sw.matrix else dict(point)
            h = params_hash(key_params)
            reps = [_seed(explicit_seed, pipeline_path, f"sweep.{j}.matrix.seed")] if explicit_seed is not None else [
                derive_seed(pipeline.seed, f"{prefix}-{h}", r) for r in range(sw.seeds)
            ]
            for seed in reps:
                cname = f"{prefix}-{h}-s{seed}"
                cases.append(make(cname, mpath, raw, {**sw.set, **point}, world, seed, key_params))

    seen: set[str] = set()
    for c in cases:
        check_name(c.name, "case name", path=pipeline_path)
        if c.name in seen:
            raise SpecError(f"duplicate case name {c.name!r} (give entries distinct 'name's)", path=pipeline_path)
        seen.add(c.name)
    return cases
