"""Benchmark of ``vinecli report`` on large synthetic batches.

Usage: ``python benchmarks/report.py [--quick] [--runs 1000] [--workers N]``

Writes four synthetic chapter-5 runs (tests/report/synth_runs.py), clones them into a batch of
``--runs`` run directories (5 % with a failed check) and times ``build_report`` on it and on a
10-run batch. Prints the total time, the cost per run and the ratio of the two. Budget:
a 1,000-run report builds in under a minute on the project's 2-core machine.
``--quick``: 100 runs (smoke run).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run (100 runs)")
    ap.add_argument("--runs", type=int, default=1000, help="runs in the large batch")
    ap.add_argument("--workers", type=int, default=None, help="figure processes (default min(4, CPUs))")
    ap.add_argument("--keep", type=Path, default=None, help="keep the generated batches and reports here")
    args = ap.parse_args()
    n = 100 if args.quick else args.runs

    sys.path.insert(0, str(REPO / "tests" / "report"))
    import synth_runs  # noqa: E402 - tests/report/synth_runs.py, imported by path

    from vinecli.report import build_report

    tmp_ctx = tempfile.TemporaryDirectory(prefix="vinecli-bench-report-")
    root = args.keep or Path(tmp_ctx.name)
    root.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    base = synth_runs.write_ci_batch(root / "base")
    small = synth_runs.clone_batch(base, root / "runs-10", 10, fail_every=5)
    large = synth_runs.clone_batch(base, root / f"runs-{n}", n, fail_every=20)
    print(f"generated 10 + {n} synthetic runs in {time.perf_counter() - t0:.1f} s ({root})")

    results = {}
    for label, runs in (("10", small), (str(n), large)):
        t1 = time.perf_counter()
        res = build_report(runs, root / f"report-{label}", workers=args.workers, overwrite=True)
        dt = time.perf_counter() - t1
        results[label] = dt
        stages = ", ".join(f"{k} {v:.2f}" for k, v in res.timings.items() if k != "total")
        print(f"{res.n_runs:5d} runs: {dt:6.2f} s  ({1000 * dt / res.n_runs:7.1f} ms/run; figures for "
              f"{res.figure_runs} runs; {res.n_failed} failing)  [{stages}]")
    ratio = results[str(n)] / results["10"]
    print(f"ratio {n} runs / 10 runs: {ratio:.2f}x time for {n // 10}x the runs")
    if n >= 1000:
        verdict = "OK" if results[str(n)] * 1000.0 / n <= 60.0 else "OVER BUDGET"
        print(f"budget: 1,000 runs in 60 s -> {verdict}")
    else:
        print("budget (1,000 runs in 60 s) applies to the full run (without --quick)")
    if args.keep is None:
        tmp_ctx.cleanup()


if __name__ == "__main__":
    main()
