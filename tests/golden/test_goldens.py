"""The golden runs (golden_runs.py): each case flown with the compiled kernel and with the pure-Python
sources must reproduce the digests in goldens.json byte for byte, so the two kernels also agree with
each other. A deliberate change of what runs produce regenerates them: `make goldens` (CONTRIBUTING.md)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from golden_runs import CASES, GOLDENS, KERNELS, compare, digest, fly_all

from vinecli import native


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory, sample_world_dir: Path) -> dict[tuple[str, str], Path]:
    # `make test` builds the kernel; a missing or stale build fails here rather than comparing pure with pure
    assert native.build_is_current(), "the compiled kernel is missing or stale: run `make native`"
    assert {world for _mission, world, _seed in CASES.values()} == {"worlds/vineyard-sample.yaml"}
    return fly_all(CASES, {"worlds/vineyard-sample.yaml": sample_world_dir}, tmp_path_factory.mktemp("goldens"))


def test_every_case_has_a_golden() -> None:
    assert set(json.loads(GOLDENS.read_text())["cases"]) == set(CASES), "run `make goldens`"


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("case", list(CASES))
def test_run_matches_its_golden(runs: dict[tuple[str, str], Path], case: str, kernel: str) -> None:
    golden = json.loads(GOLDENS.read_text())["cases"][case]
    assert (golden["mission"], golden["world"], golden["seed"]) == CASES[case]
    moved = compare(golden["digest"], digest(runs[(case, kernel)]))
    assert not moved, (f"{case} ({kernel} kernel) differs from tests/golden/goldens.json; if on purpose, "
                       "regenerate with `make goldens` in a commit of its own:\n  " + "\n  ".join(moved[:30]))
