"""Benchmark of ``vinecli report``: large synthetic batches, and the CI runs against another checkout.

Usage: ``python benchmarks/report.py [--quick] [--runs 1000] [--workers N]``
       ``python benchmarks/report.py --ci-runs RUNS --baseline-src CHECKOUT [--repeats 3]``

Synthetic (default): writes four synthetic chapter-5 runs (tests/report/synth_runs.py), clones them into a batch of
``--runs`` run directories (5 % with a failed check) and times ``build_report`` on it and on a 10-run batch. Prints
the total time, the cost per run and the ratio of the two. Budget: a 1,000-run report builds in under a
minute on the project's 2-core machine. ``--quick``: 100 runs (smoke run).

CI runs: ``vinecli report RUNS`` (the runs of ``vinecli run batch pipelines/ci.yaml``) by the checkout
of ``--baseline-src`` (e.g. a ``git worktree`` of main; run with this venv's Python, its source first on the path)
and by this one with an empty cache, then again with the cache that run filled; interleaved ``--repeats`` times.
Prints wall and CPU seconds (the report's processes and their children), the page's size and its figures and maps,
and the ratios to the baseline. Budget: <= 3 s and <= 3 MB, <= 1 s cached (on an idle 2-core machine: compare the
ratios when the machine is shared).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _report_once(src: Path, runs: Path, out: Path, cache: Path | None) -> dict[str, float]:
    """One ``vinecli report`` by the source tree ``src`` in a fresh process: wall s, CPU s (with its children),
    page bytes, figures and maps in the page."""
    import os
    import re
    import resource
    import subprocess

    env = {**os.environ, "PYTHONPATH": str(src), "VINECLI_CACHE_DIR": str(cache) if cache else "off",
           "MPLBACKEND": "Agg"}
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as installed: compiled modules cached, not compiled each start
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "vinecli", "report", str(runs), "--out", str(out), "--overwrite"],
                   env=env, check=False, capture_output=True, cwd=out.parent)  # not this checkout's folder first
    wall = time.perf_counter() - t0
    _reap_orphans()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    html = (out / "report.html").read_text(encoding="utf-8")
    return {"wall_s": wall, "cpu_s": (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime),
            "bytes": float(len(html.encode())), "figures": float(len(re.findall(r'<figure id="[^"]*">\s*<img', html))),
            "maps": float(html.count('<script type="application/json" class="fm-data">'))}


def _become_subreaper() -> None:
    """Orphaned descendants (a fork server and the workers forked from it) become this process's children (Linux
    PR_SET_CHILD_SUBREAPER), so their CPU time counts in RUSAGE_CHILDREN once they are reaped."""
    import ctypes

    try:
        ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)
    except (OSError, AttributeError):
        print("note: not Linux: the CPU of orphaned worker processes is not counted")


def _reap_orphans() -> None:
    import os

    while True:
        try:
            os.waitpid(-1, 0)
        except ChildProcessError:
            return


def ci_comparison(runs: Path, baseline_src: Path, repeats: int) -> None:
    """The CI runs' report by ``baseline_src`` and by this checkout (empty cache, then cached), interleaved."""
    import os
    import statistics
    import tempfile

    _become_subreaper()
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="vinecli-bench-report-ci-") as tmp:
        root = Path(tmp)
        res: dict[str, list[dict[str, float]]] = {"baseline": [], "this, no cache": [], "this, cached": []}
        (root / "base").mkdir()
        for k in range(repeats):
            cache = root / f"cache-{k}"
            res["baseline"].append(_report_once(baseline_src, runs, root / "base", None))
            res["this, no cache"].append(_report_once(REPO, runs, root / "this", cache))
            res["this, cached"].append(_report_once(REPO, runs, root / "this", cache))
        base = {m: statistics.median(r[m] for r in res["baseline"]) for m in ("wall_s", "cpu_s")}
        load1 = os.getloadavg()
        print(f"report of {runs} ({repeats} interleaved repeats, medians; baseline {baseline_src}); load average "
              f"(1 min) {load0[0]:.2f} before, {load1[0]:.2f} after, on {os.cpu_count()} CPUs")
        for label, rows in res.items():
            med = {m: statistics.median(r[m] for r in rows) for m in rows[0]}
            print(f"  {label:15s} wall {med['wall_s']:6.2f} s ({base['wall_s'] / med['wall_s']:5.2f}x faster)  "
                  f"cpu {med['cpu_s']:6.2f} s ({base['cpu_s'] / med['cpu_s']:5.2f}x less)  "
                  f"{med['bytes'] / 1e6:5.2f} MB  {med['figures']:.0f} figures  {med['maps']:.0f} maps")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run (100 runs)")
    ap.add_argument("--runs", type=int, default=1000, help="runs in the large batch")
    ap.add_argument("--workers", type=int, default=None, help="figure processes (default min(4, CPUs))")
    ap.add_argument("--keep", type=Path, default=None, help="keep the generated batches and reports here")
    ap.add_argument("--ci-runs", type=Path, default=None, help="runs of pipelines/ci.yaml: compare with --baseline-src")
    ap.add_argument("--baseline-src", type=Path, default=None, help="another checkout (e.g. a worktree of main)")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved repeats of the CI comparison")
    args = ap.parse_args()
    if args.ci_runs is not None:
        if args.baseline_src is None:
            ap.error("--ci-runs needs --baseline-src")
        ci_comparison(args.ci_runs, args.baseline_src.resolve(), args.repeats)
        return
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
