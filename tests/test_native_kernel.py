"""The compiled kernel (vinecli/native.py) against its pure-Python reference.

A mission flown with the kernel mypyc compiled and with ``VINECLI_PURE_PYTHON=1`` (the sources) must be
bit-identical: every timeseries column, every event and every metric except timings. The golden runs
(tests/golden) fly takeoff, spray, gust and a mission with every other law on both kernels against
stored digests; here the whole-field refill job (long, many sorties) and a canopy dose flown at segment rates are
compared between the two.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from repo_paths import REPO

from vinecli import native


@pytest.fixture()
def compiled() -> None:
    """The compiled kernel must be built from the current sources: `make test` builds it, and a missing or stale
    build fails here. The runs below choose compiled or pure Python themselves, whatever this process runs."""
    assert native.build_is_current(), "the compiled kernel is missing or stale: run `make native`"


def _fly(mission: str, world: Path, out: Path, *, pure: bool) -> Path:
    env = {**os.environ, "PYTHONPATH": str(REPO), native.PURE_ENV: "1" if pure else "0"}
    subprocess.run([sys.executable, "-m", "vinecli", "run", "mission", str(REPO / "pipelines" / "missions" / mission),
                    "--world", str(world), "--out", str(out), "--seed", "1"], env=env, check=True,
                   capture_output=True, text=True)
    (run,) = [p for p in out.iterdir() if (p / "summary.json").is_file()]
    return run


def _events(run: Path) -> list[dict[str, object]]:
    return [{k: v for k, v in json.loads(line).items() if k != "wall_s"}
            for line in (run / "events.jsonl").read_text().splitlines()]


def test_a_new_process_runs_the_compiled_kernel(compiled: None) -> None:
    env = {**os.environ, "PYTHONPATH": str(REPO), native.PURE_ENV: "0"}
    out = subprocess.run([sys.executable, "-c", "import vinecli.native as n, vinecli.sim.runner as r; "
                          "print(n.state, n.is_compiled(r), n.stale_sources())"], env=env, check=True,
                         capture_output=True, text=True)
    assert out.stdout.split() == ["compiled", "True", "[]"]


def _identical(fast: Path, ref: Path) -> dict[str, object]:
    """Assert two runs bit-identical (module docstring); the compiled run's summary."""
    a, b = pq.read_table(fast / "timeseries.parquet"), pq.read_table(ref / "timeseries.parquet")
    assert a.column_names == b.column_names and a.num_rows == b.num_rows > 1000
    for col in a.column_names:
        assert np.array_equal(a[col].to_numpy(), b[col].to_numpy(), equal_nan=True), col
    assert _events(fast) == _events(ref)
    sa, sb = (json.loads((r / "summary.json").read_text()) for r in (fast, ref))
    for key in ("status", "detail", "metrics", "checks", "failsafes"):
        assert sa.get(key) == sb.get(key), key
    ka, kb = sa["kernel"], sb["kernel"]  # each run says which kernel ran, built from the same sources
    assert (ka["kind"], kb["kind"]) == ("compiled", "pure") and ka["sources_sha256"] == kb["sources_sha256"]
    assert "-ffp-contract=off" in ka["cflags"] and ka["compiler"].startswith("mypyc")
    return {"compiled": sa, "pure": sb}


def test_compiled_and_pure_python_runs_are_bit_identical(compiled: None, sample_world_dir: Path, tmp_path: Path) -> None:
    fast = _fly("job.yaml", sample_world_dir, tmp_path / "compiled", pure=False)
    ref = _fly("job.yaml", sample_world_dir, tmp_path / "pure", pure=True)
    s = _identical(fast, ref)
    ta, tb = s["compiled"]["timing"]["cpu_per_step_us"], s["pure"]["timing"]["cpu_per_step_us"]  # type: ignore[index]
    assert ta < tb, (ta, tb)  # and the kernel is the faster of the two


def test_segment_rates_fly_bit_identical(compiled: None, sample_world_dir: Path, tmp_path: Path) -> None:
    """A canopy dose (pipelines/missions/dose/lwa.yaml): the spray phase's rate path, look-ahead and speed caps."""
    fast = _fly("dose/lwa.yaml", sample_world_dir, tmp_path / "compiled", pure=False)
    ref = _fly("dose/lwa.yaml", sample_world_dir, tmp_path / "pure", pure=True)
    s = _identical(fast, ref)
    assert s["compiled"]["as_applied"] == s["pure"]["as_applied"]  # type: ignore[index]


def test_pure_python_switch_imports_the_sources() -> None:
    env = {**os.environ, "PYTHONPATH": str(REPO), native.PURE_ENV: "1"}
    out = subprocess.run([sys.executable, "-c", "import vinecli.native as n, vinecli.sim.runner as r, "
                          "vinecli.flight.motor as m; print(n.state, n.is_compiled(r), r.__file__.endswith('.py'), "
                          "m.__file__.endswith('.py'))"], env=env, check=True, capture_output=True, text=True)
    assert out.stdout.split() == ["pure", "False", "True", "True"]


def test_a_changed_source_makes_the_kernel_stale(tmp_path: Path) -> None:
    root = tmp_path / "vinecli"
    for rel in native.KERNEL:
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(native.PACKAGE_DIR / rel, root / rel)
    manifest = tmp_path / "native.json"
    assert native.stale_sources(manifest, root) is None  # no build recorded: run the sources
    manifest.write_text(json.dumps({"sources": native.source_digests(root)}))
    assert native.stale_sources(manifest, root) == []
    (root / "types.py").touch()  # a new mtime with the same content (a checkout): still the build's source
    os.utime(root / "types.py", ns=(1, 1))
    assert native.stale_sources(manifest, root) == []
    with (root / "flight" / "motor.py").open("a") as f:
        f.write("\n# edited after the build\n")
    assert native.stale_sources(manifest, root) == ["flight/motor.py"]
    manifest.write_text("{not json")
    assert native.stale_sources(manifest, root) is None
