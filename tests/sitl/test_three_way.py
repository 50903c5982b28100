"""The real three-way comparison: pipelines/missions/spray-two-rows.yaml (rows 1 and 5 once at 20 L/ha, return
and land) flown by the built-in autopilot, real PX4 SITL and real ArduCopter SITL with ``vinecli run compare``
(``../shared`` px4 and ardupilot; skips with the reason without them), each row's dose judged.

What a grower gets from each, as measured (README "Compare autopilots on one mission", BENCHMARKS.md): every
row's mean dose within ±15 % of the asked rate under all three; the built-in autopilot passes every default
dose check; the firmwares misdose only the pass ends, where the vehicle accelerates out of a turn or brakes into
a run-out the fence shortened: PX4 v1.15 keeps a constant flow (DO_SET_ACTUATOR), so the dose there rises as
1/speed (hot spots), ArduPilot's AC_Sprayer scales the pump with ground speed but cuts it below SPRAY_SPEED_MIN
(gaps). Mid-row they hold the dose: waypoints that made them slow down mid-row would fail this test.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.repo_paths import REPO
from tests.sitl.px4.real_px4 import px4_bin  # noqa: F401 - fixture

pytestmark = [pytest.mark.ardupilot, pytest.mark.px4, pytest.mark.timeout(1200)]

END_M = 3.0  # a pass end's stretch: a firmware's acceleration or braking at 2 m/s, with AC_Sprayer's 1 s off delay


@pytest.fixture(scope="module")
def three_way(px4_bin: Path, ardupilot_bin: Path, sample_world_dir: Path,  # noqa: F811
              tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, Path]:
    """The comparison on worlds/vineyard-sample.yaml as the session built it (``sample_world_dir``)."""
    from vinecli.batch.compare_autopilots import compare_autopilots

    out = tmp_path_factory.mktemp("three-way")
    _res, cmp = compare_autopilots(REPO / "pipelines" / "missions" / "spray-two-rows.yaml",
                                   sample_world_dir, out, workers=3, px4_bin=px4_bin,
                                   ardupilot_bin=ardupilot_bin)
    assert cmp is not None
    return cmp, out


def _faults(run: Path) -> list[tuple[str, float, float, float]]:
    """(kind, distance from the nearer end of the planned stretch m, length m, ratio) of each dose fault."""
    doc = json.loads((run / "deposition.json").read_text())
    out = []
    for r in doc["rows"]:
        a, b = r["planned_m"]
        for f in r["faults"]:
            out.append((f["kind"], min(f["from_m"] - a, b - f["to_m"]), f["to_m"] - f["from_m"], f["ratio"]))
    return out


def test_three_autopilots_fly_the_same_spray_and_each_row_gets_its_dose(three_way):
    cmp, out = three_way
    by = {r["autopilot"]: r for r in cmp["runs"]}
    assert set(by) == {"builtin", "px4", "ardupilot"}
    assert by["px4"]["firmware"] == "PX4 1.15.4" and by["ardupilot"]["firmware"].startswith("ArduCopter 4.7.0")
    print(json.dumps({k: [(x["mean_rate_lpha"], x["rate_ratio"]) for x in r["rows"]] for k, r in by.items()}))
    for name, r in by.items():
        s = json.loads((Path(r["dir"]) / "summary.json").read_text())
        assert r["status"] == "completed", (name, r["status"], s.get("status_reason"))
        assert s["metrics"].get(f"{name}_stalls", 0) == 0
        assert len(r["rows"]) == 2 and all(abs(x["rate_ratio"] - 1.0) <= 0.15 for x in r["rows"]), (name, r["rows"])
        assert r["row_coverage_fraction"] >= 0.95
        failed = {c["name"] for c in s["checks"] if not c["passed"]}
        assert not failed - {"dose_hot_spots", "dose_gaps", "dose_coverage"}, (name, failed)
    assert by["builtin"]["dose_checks_passed"] is True
    for name, kind in (("px4", "hot"), ("ardupilot", "gap")):  # the firmwares' sprayer logic, at the pass ends only
        faults = _faults(Path(by[name]["dir"]))
        assert all(k == kind and edge <= 0.5 and length <= END_M for k, edge, length, _ in faults), (name, faults)
    assert all(1.0 < ratio < 2.0 for _, _, _, ratio in _faults(Path(by["px4"]["dir"])))  # constant flow, ~1/speed
    assert (out / "comparison.png").stat().st_size > 20_000 and (out / "comparison.json").is_file()
