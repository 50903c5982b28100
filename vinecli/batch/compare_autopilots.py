"""``vinecli run compare``: one mission, world and seed flown by several autopilots (the built-in one,
PX4 and ArduPilot by default) as one batch, then compared side by side.

The runs go to ``OUT/<mission>-<autopilot>/`` with ``OUT/batch.json`` as any batch (so ``vinecli report OUT``
shows them, with the comparison on its first page); ``OUT/comparison.json``
(:func:`vinecli.runs.compare.compare_runs`) and ``OUT/comparison.png`` (figA) are written beside them.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vinecli.batch.pipeline import MissionEntry, PipelineSpec
from vinecli.batch.run import BatchResult, ProgressFn, run_batch
from vinecli.errors import InputError
from vinecli.locks import output_lock
from vinecli.outputs import json_text, write_bytes_atomic, write_text_atomic

AUTOPILOTS = ("builtin", "px4", "ardupilot")
COMPARISON_JSON = "comparison.json"
COMPARISON_PNG = "comparison.png"


# parameters: keyword-only options, each with its default, one per `vinecli run compare` option; a caller names the ones it sets
def compare_autopilots(mission: str | Path, world: str | Path, runs_dir: str | Path, *,
                       autopilots: Sequence[str] = AUTOPILOTS, seed: int = 0, workers: int = 1,
                       px4_bin: str | Path | None = None, ardupilot_bin: str | Path | None = None,
                       timeout_s: float | None = None, progress: ProgressFn | None = None
                       ) -> tuple[BatchResult, dict[str, Any] | None]:
    """Fly ``mission`` on ``world`` with each of ``autopilots`` (same seed), compare; the batch and the comparison
    (None when fewer than two runs left a run directory)."""
    from vinecli.missions.spec_io import load_mission
    from vinecli.report.autopilots import comparison_png
    from vinecli.runs.compare import compare_runs

    names = list(dict.fromkeys(autopilots))
    if len(names) < 2:
        raise InputError(f"--autopilots: give two or more to compare, got {', '.join(names) or 'none'}")
    if "px4" in names and px4_bin is None:
        raise InputError("comparing with px4 needs --px4-bin (or leave px4 out of --autopilots)")
    if "ardupilot" in names and ardupilot_bin is None:
        raise InputError("comparing with ardupilot needs --ardupilot-bin (or leave ardupilot out of --autopilots)")
    mpath = Path(mission).resolve()
    spec = load_mission(mpath)
    pipeline = PipelineSpec(
        name=f"compare-{spec.name}", description=f"{spec.name} flown by {', '.join(names)} (seed {seed})",
        world=str(Path(world).resolve()), seed=seed, timeout_s=timeout_s or 900.0,
        missions=[MissionEntry(mission=str(mpath), name=f"{spec.name}-{ap}", seed=seed, set={"autopilot": ap})
                  for ap in names])
    out = Path(runs_dir)
    result = run_batch(pipeline, out, workers=workers, px4_bin=px4_bin, ardupilot_bin=ardupilot_bin, progress=progress)
    dirs = [out / c.run_id for c in result.cases if (out / c.run_id / "summary.json").is_file()]
    if len(dirs) < 2:
        return result, None
    cmp = compare_runs(dirs)
    with output_lock(out, inside=True):  # the batch's lock; a file or link planted in OUT is replaced, never followed
        write_text_atomic(out / COMPARISON_JSON, json_text(cmp))
        write_bytes_atomic(out / COMPARISON_PNG, comparison_png(cmp))
    return result, cmp


__all__ = ["AUTOPILOTS", "COMPARISON_JSON", "COMPARISON_PNG", "compare_autopilots"]
