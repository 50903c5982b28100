"""A spray pass in a crosswind on the bundled sample field (real loop, autopilot, deposition): the far field lands
along the rows without lumps. Its lifted parcels are merged over windows of release time to keep the far field within
MAX_FAR_PARCELS; with 60,000 the window of this 94 s run grew to 3.2 s (6.4 m of flight) and the spray landed in lumps
one window apart (dose_hot_spots 1.66x, every ~6.5 m); the default dose checks judge it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.repo_paths import REPO
from vinecli.runs.mission import run_mission
from vinecli.runs.request import RunRequest

MISSION = (REPO / "pipelines" / "missions" / "spray-two-rows.yaml").read_text()


@pytest.fixture(scope="module")
def crosswind_run(sample_world_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("crosswind")
    calm = "wind: {law: {type: constant, velocity_enu: [0.0, 0.0, 0.0]}}"
    assert calm in MISSION
    (d / "m.yaml").write_text(MISSION.replace("name: spray-two-rows", "name: crosswind-two-rows").replace(
        calm, "wind: {law: {type: constant, velocity_enu: [1.5, 0.0, 0.0]}}"))
    return Path(run_mission(RunRequest(d / "m.yaml", sample_world_dir, d / "runs", seed=0)).run_dir)


def test_a_crosswind_spray_lands_along_its_rows_without_lumps(crosswind_run: Path) -> None:
    summary = json.loads((crosswind_run / "summary.json").read_text())
    checks = {c["name"]: c for c in summary["checks"]}
    assert summary["status"] == "completed"
    print({k: c["value"] for k, c in checks.items() if k.startswith("dose")})
    for name in ("dose_gaps", "dose_row_rates", "dose_coverage"):
        assert checks[name]["passed"], (name, checks[name]["value"], checks[name]["bound"])
    # lumps one merge window apart were a hot 1 m window every ~6.5 m (1.66x); this seed's spray has at most one
    # window at the check's 1.3x bound per row, merged or not (1.300x unmerged)
    hot = [[f["ratio"] for f in r["faults"] if f["kind"] == "hot"]
           for r in json.loads((crosswind_run / "deposition.json").read_text())["rows"]]
    assert len(hot) == 2 and all(len(h) <= 1 for h in hot) and max(sum(hot, [1.0])) < 1.35, hot
