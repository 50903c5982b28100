"""The golden runs: a few short missions whose outputs must stay the same bytes, on both kernels.

Each case is one ``vinecli run mission`` (mission, world, seed) flown in its own process twice: with the
compiled kernel and with ``VINECLI_PURE_PYTHON=1``. What a run wrote is reduced to a digest
(:func:`digest`): per time-series column a hash of its bytes, and hashes of ``summary.json`` (without
the machine-dependent ``timing``, ``started_utc``, ``world.dir`` and ``kernel``), ``events.jsonl``,
``deposition.json`` (without its ``transport_s`` timing) and the pixels of ``deposition.tif``.
``goldens.json`` holds the digests and a few summary numbers; ``test_goldens.py`` flies the cases and
compares. A change that moves what runs produce on purpose regenerates them in a commit of its own:

    make goldens        # = .venv/bin/python tests/golden/golden_runs.py (needs `make native`)

which flies every case on both kernels, refuses to write when the kernels disagree, and prints what
moved against the old file (columns and summary numbers, old -> new): say that in the commit message.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
GOLDENS = HERE / "goldens.json"
KERNELS = ("compiled", "pure")
#: name -> (mission file, world spec, seed); short missions that together run every physics law
CASES: dict[str, tuple[str, str, int]] = {
    "takeoff": ("pipelines/missions/takeoff.yaml", "worlds/vineyard-sample.yaml", 1),
    "spray": ("pipelines/missions/spray.yaml", "worlds/vineyard-sample.yaml", 1),
    "gust": ("pipelines/missions/gust.yaml", "worlds/vineyard-sample.yaml", 2),
    "laws": ("tests/golden/laws.yaml", "worlds/vineyard-sample.yaml", 1),
}
#: summary.json fields that depend on the machine or say which kernel ran (not what it computed)
SUMMARY_DROP = ("timing", "started_utc", "kernel")
#: summary numbers kept readable in goldens.json (what moved, by how much, after a regeneration)
NUMBERS = ("liftoff_s", "touchdown_s", "tank_empty_s", "energy_wh", "battery_soc_end", "max_impact_speed_mps",
           "hpos_error_max_m", "cross_track_rms_m", "final_mass_kg", "steps")


def _h(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:16]


def _canon(doc: Any) -> bytes:
    return json.dumps(doc, sort_keys=True, separators=(",", ":")).encode()


def digest(run: Path) -> dict[str, Any]:
    """What must not change in a run directory, as hashes (see the module doc)."""
    import numpy as np
    import pyarrow.parquet as pq

    table = pq.read_table(run / "timeseries.parquet")
    columns = {name: _h(np.ascontiguousarray(table[name].to_numpy()).tobytes()) for name in table.column_names}
    summary = json.loads((run / "summary.json").read_text())
    for key in SUMMARY_DROP:
        summary.pop(key, None)
    summary.get("world", {}).pop("dir", None)
    out: dict[str, Any] = {"rows": table.num_rows, "columns": columns, "summary": _h(_canon(summary)),
                           "events": _h((run / "events.jsonl").read_bytes())}
    dep = run / "deposition.json"
    if dep.is_file():
        doc = json.loads(dep.read_text())
        doc.pop("transport_s", None)
        out["deposition_json"] = _h(_canon(doc))
        import rasterio

        with rasterio.open(run / "deposition.tif") as r:
            out["deposition_tif"] = _h(np.ascontiguousarray(r.read()).tobytes() + repr(tuple(r.transform)).encode())
    return out


def numbers(run: Path) -> dict[str, Any]:
    """A few readable summary numbers of a run (status, simulated time, some metrics)."""
    s = json.loads((run / "summary.json").read_text())
    m = s["metrics"]
    return {"status": s["status"], "sim_time_s": s["sim_time_s"], **{k: m.get(k) for k in NUMBERS if k in m}}


def build_world(spec: str, into: Path) -> Path:
    """``vinecli world build`` of ``spec`` (repo-relative) into ``into``/<stem>, once per directory."""
    from vinecli.world import build_world as build

    out = into / Path(spec).stem
    return out if (out / "world.json").is_file() else build(REPO / spec, out)


def fly(case: str, kernel: str, world_dir: Path, out: Path) -> Path:
    """Fly ``case`` with ``kernel`` in a new process; the run directory."""
    mission, _world, seed = CASES[case]
    env = {**os.environ, "PYTHONPATH": str(REPO), "VINECLI_PURE_PYTHON": "1" if kernel == "pure" else "0",
           "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    dest = out / kernel
    r = subprocess.run([sys.executable, "-m", "vinecli", "run", "mission", str(REPO / mission), "--world",
                        str(world_dir), "--out", str(dest), "--seed", str(seed), "--run-id", case],
                       env=env, capture_output=True, text=True)
    if r.returncode not in (0, 1):  # 1: a check failed, still a run to compare
        raise RuntimeError(f"{case} ({kernel}) exited {r.returncode}: {r.stderr[-2000:]}")
    return dest / case


def build_worlds(cases: Iterable[str], into: Path) -> dict[str, Path]:
    """The built world of every world spec the cases fly in (repo-relative spec -> world directory)."""
    return {spec: build_world(spec, into) for spec in sorted({CASES[c][1] for c in cases})}


def fly_all(cases: Iterable[str], world_dirs: dict[str, Path], out: Path, workers: int = 2) -> dict[tuple[str, str], Path]:
    """Every (case, kernel) run, ``workers`` processes at a time, in the built worlds ``world_dirs``
    (:func:`build_worlds`)."""
    cases = list(cases)
    todo = [(c, k) for c in cases for k in KERNELS]
    with ThreadPoolExecutor(workers) as pool:
        runs = pool.map(lambda ck: fly(ck[0], ck[1], world_dirs[CASES[ck[0]][1]], out / ck[0]), todo)
        return dict(zip(todo, runs, strict=True))


def compare(expected: dict[str, Any], got: dict[str, Any]) -> list[str]:
    """Differences between two digests, one line each (empty when identical)."""
    lines = []
    for key in sorted(set(expected) | set(got)):
        a, b = expected.get(key), got.get(key)
        if key == "columns" and isinstance(a, dict) and isinstance(b, dict):
            lines += [f"column {c}: {a.get(c)} -> {b.get(c)}" for c in sorted(set(a) | set(b)) if a.get(c) != b.get(c)]
        elif a != b:
            lines.append(f"{key}: {a} -> {b}")
    return lines


def regenerate() -> int:
    """Fly every case on both kernels and write goldens.json (see the module doc)."""
    sys.path.insert(0, str(REPO))
    from vinecli import native

    if not native.build_is_current():
        print("the compiled kernel is missing or stale: run `make native` first", file=sys.stderr)
        return 2
    old = json.loads(GOLDENS.read_text())["cases"] if GOLDENS.is_file() else {}
    cases: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="vinecli-goldens-") as tmp:
        runs = fly_all(CASES, build_worlds(CASES, Path(tmp) / "worlds"), Path(tmp) / "runs")
        for name, (mission, world, seed) in CASES.items():
            d = {k: digest(runs[(name, k)]) for k in KERNELS}
            if d["compiled"] != d["pure"]:
                print(f"{name}: the compiled and pure-Python kernels disagree:\n  "
                      + "\n  ".join(compare(d["pure"], d["compiled"])), file=sys.stderr)
                return 1
            cases[name] = {"mission": mission, "world": world, "seed": seed,
                           "numbers": numbers(runs[(name, "compiled")]), "digest": d["compiled"]}
    for name, case in cases.items():
        before = old.get(name)
        if before is None:
            print(f"{name}: new")
        elif before["digest"] == case["digest"]:
            print(f"{name}: unchanged")
        else:
            moved = compare(before["digest"], case["digest"])
            print(f"{name}: {len(moved)} digest(s) moved")
            for k in sorted(set(before["numbers"]) | set(case["numbers"])):
                if before["numbers"].get(k) != case["numbers"].get(k):
                    print(f"  {k}: {before['numbers'].get(k)} -> {case['numbers'].get(k)}")
    doc = {"about": "golden runs (tests/golden/golden_runs.py); regenerate with `make goldens`", "cases": cases}
    GOLDENS.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n")
    print(f"wrote {GOLDENS.relative_to(REPO)} ({len(cases)} cases x {len(KERNELS)} kernels, identical)")
    return 0


if __name__ == "__main__":
    sys.exit(regenerate())
