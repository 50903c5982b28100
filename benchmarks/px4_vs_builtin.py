"""The CI missions flown by the built-in autopilot and by real PX4 v1.15 SITL, side by side.

Runs ``pipelines/ci-px4.yaml`` (takeoff, overload, spray on two rows, gust on the sample vineyard)
once per seed with ``autopilot: builtin`` and once with PX4 (``--px4-bin``, each case its own PX4
process, ``--workers 2``), then prints the behaviour figures (:mod:`vinecli.runs.behaviour`),
checks passed, wall time and lockstep stalls as a Markdown table (median over seeds).

    .venv/bin/python benchmarks/px4_vs_builtin.py --px4-bin /tmp/px4/px4-sitl-v1.15.4-linux-x86_64/bin/px4 [--seeds 3]

Without ``--px4-bin`` the tarball in ``../shared/px4`` is extracted into a temporary directory.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

FIGURES = ("takeoff_time_s", "hover_error_max_m", "hover_error_rms_m", "spray_path_p95_m", "landing_time_s")


def run(pipeline: Path, out: Path, seed: int, autopilot: str, px4_bin: Path | None) -> dict[str, Any]:
    """One batch of the pipeline; per case: figures, passed, status, wall time, stalls."""
    from vinecli.batch import run_batch
    from vinecli.batch.pipeline import load_pipeline
    from vinecli.runs import rundir
    from vinecli.runs.behaviour import behaviour_figures

    spec = load_pipeline(pipeline).model_copy(update={"autopilot": autopilot, "seed": seed})
    os.chdir(pipeline.parent)  # a PipelineSpec's relative paths resolve against the working directory
    t0 = time.perf_counter()
    res = run_batch(spec, out, workers=2, px4_bin=px4_bin if autopilot == "px4" else None, world=_world(out))
    wall = time.perf_counter() - t0
    cases: dict[str, Any] = {"_batch_wall_s": wall}
    for c in res.cases:
        d = out / c.run_id
        summary = rundir.read_summary(d)
        cases[c.case] = {"passed": c.passed, "status": c.status, "wall_s": c.wall_time_s,
                         "stalls": summary["metrics"].get("px4_stalls"), **behaviour_figures(d)}
    return cases


_BUILT: dict[str, Path] = {}


def _world(out: Path) -> Path:
    """The sample vineyard, built once for every batch of this script."""
    if "w" not in _BUILT:
        from vinecli.world import build_world

        w = out.parent / "_world"
        build_world(REPO / "worlds" / "vineyard-sample.yaml", w)
        _BUILT["w"] = w
    return _BUILT["w"]


def _med(vals: list[Any]) -> str:
    nums = [v for v in vals if isinstance(v, (int, float))]
    if not nums:
        return "—"
    m = statistics.median(nums)
    return f"{m:.2f}" + (f" ({min(nums):.2f}–{max(nums):.2f})" if len(nums) > 1 else "")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--px4-bin", type=Path, default=None)
    ap.add_argument("--seeds", type=int, default=3)
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="px4-vs-builtin-"))
    px4_bin = args.px4_bin
    if px4_bin is None:
        from tests.sitl.px4.real_px4 import extract_px4, px4_tarballs

        tars = px4_tarballs()
        if not tars:
            sys.exit("no --px4-bin and no ../shared/px4 tarball")
        px4_bin = extract_px4(tars[-1], tmp / "px4")
    pipeline = REPO / "pipelines" / "ci-px4.yaml"
    results: dict[str, list[dict[str, Any]]] = {"builtin": [], "px4": []}
    for seed in range(args.seeds):
        for autopilot in ("builtin", "px4"):
            results[autopilot].append(run(pipeline, tmp / f"{autopilot}-s{seed}", seed, autopilot, px4_bin))
    cases = [c for c in results["px4"][0] if not c.startswith("_")]
    print(f"| case | figure | built-in | PX4 v1.15 SITL |  (median (min–max) over {args.seeds} seeds)")
    print("|---|---|---|---|")
    for case in cases:
        for fig in (*FIGURES, "wall_s", "stalls"):
            b = [r[case][fig] for r in results["builtin"]]
            p = [r[case][fig] for r in results["px4"]]
            if all(v is None for v in b + p):
                continue
            print(f"| {case} | {fig} | {_med(b)} | {_med(p)} |")
        for who in ("builtin", "px4"):
            bad = [r[case]["status"] for r in results[who] if not r[case]["passed"]]
            print(f"| {case} | checks passed ({who}) | {args.seeds - len(bad)}/{args.seeds} {bad or ''} | |")
    for who in ("builtin", "px4"):
        print(f"batch wall ({who}, --workers 2): " + _med([r["_batch_wall_s"] for r in results[who]]) + " s")


if __name__ == "__main__":
    main()
