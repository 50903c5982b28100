"""Where the test suite's time goes: reads the output of ``pytest --durations=0`` (one or two runs) and prints the
slowest tests, the seconds per file and per scheduling scope (tests/xdist_scopes.py: a module, or a firmware's
chain of real-firmware tests), and the run's wall time; ``--write-scopes`` writes the seconds per scope to
tests/scope_seconds.json, which the scheduler of tests/conftest.py reads to start the longest scopes first;
``--rescale-scopes`` (two runs of some scopes, before and after a change, on one machine in one session) keeps the
table's whole-suite figures and multiplies each scope of both runs by its after/before ratio.

    python benchmarks/suite_durations.py before.txt [after.txt] [--top 20] [--write-scopes | --rescale-scopes]
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
from xdist_scopes import SCOPE_SECONDS, scope_of  # noqa: E402

LINE = re.compile(r"^\s*([0-9.]+)s (setup|call|teardown)\s+(\S+)")
WALL = re.compile(r"^=* ?(\d+ (?:passed|failed).*) in ([0-9.]+)s")


def read_durations(path: Path) -> tuple[list[tuple[float, str, str]], str]:
    """((seconds, phase, node id) of every test phase, the summary line with the wall time)."""
    rows, summary = [], ""
    for line in path.read_text(errors="replace").splitlines():
        if m := LINE.match(line):
            rows.append((float(m[1]), m[2], m[3]))
        elif m := WALL.search(line):
            summary = f"{m[1]} in {m[2]} s"
    return rows, summary


def sums(rows: list[tuple[float, str, str]], key: object) -> dict[str, float]:
    out: dict[str, float] = defaultdict(float)
    for sec, _phase, nodeid in rows:
        out[key(nodeid)] += sec  # type: ignore[operator]
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="pytest --durations=0 outputs (before [after])")
    ap.add_argument("--top", type=int, default=20)
    ap.add_argument("--write-scopes", action="store_true", help=f"write {SCOPE_SECONDS.relative_to(REPO)}")
    ap.add_argument("--rescale-scopes", action="store_true",
                    help=f"multiply the scopes of both runs in {SCOPE_SECONDS.relative_to(REPO)} by after/before")
    a = ap.parse_args()
    runs = [read_durations(p) for p in a.runs]
    for path, (rows, summary) in zip(a.runs, runs, strict=True):
        total = sum(r[0] for r in rows)
        print(f"\n## {path}: {summary}; {total:.0f} s of test time in all")
        print(f"\nslowest {a.top}:")
        for sec, phase, nodeid in sorted(rows, reverse=True)[:a.top]:
            print(f"  {sec:7.2f}s {phase:8s} {nodeid}")
        by_scope = sums(rows, lambda n: scope_of(REPO, n))
        print("\nscopes (one worker each), longest first:")
        for scope, sec in list(by_scope.items())[:a.top]:
            print(f"  {sec:7.1f}s {scope}")
    if len(runs) == 2:
        before, after = (sums(rows, lambda n: n.split("::", 1)[0]) for rows, _ in runs)
        print("\nfiles, before -> after (s):")
        for f in sorted(before.keys() | after.keys(), key=lambda f: -before.get(f, 0.0))[:a.top]:
            print(f"  {before.get(f, 0.0):7.1f} -> {after.get(f, 0.0):7.1f}  {f}")
    if a.write_scopes:
        scopes = sums(runs[-1][0], lambda n: scope_of(REPO, n))
        _write_scopes(scopes)
    if a.rescale_scopes and len(runs) == 2:
        before, after = (sums(rows, lambda n: scope_of(REPO, n)) for rows, _ in runs)
        scopes = json.loads(SCOPE_SECONDS.read_text())
        for scope in before.keys() & after.keys() & scopes.keys():
            print(f"  {scopes[scope]:7.1f} -> {scopes[scope] * after[scope] / before[scope]:7.1f}  {scope}")
            scopes[scope] *= after[scope] / before[scope]
        _write_scopes(scopes)


def _write_scopes(scopes: dict[str, float]) -> None:
    ordered = dict(sorted(scopes.items(), key=lambda kv: -kv[1]))
    SCOPE_SECONDS.write_text(json.dumps({k: round(v, 1) for k, v in ordered.items()}, indent=1) + "\n")
    print(f"\nwrote {SCOPE_SECONDS} ({len(scopes)} scopes)")


if __name__ == "__main__":
    main()
