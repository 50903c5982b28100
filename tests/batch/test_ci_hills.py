"""The second DSM world: pipelines/ci-hills.yaml (the four CI missions on worlds/lidar-hills.yaml,
the lidR LiDAR DTM without CRS, origin given) passes every check through the real loop."""

from __future__ import annotations

import json
from pathlib import Path

from repo_paths import REPO

from vinecli.batch import run_batch


def test_ci_hills_pipeline_passes_every_check(tmp_path: Path) -> None:
    res = run_batch(REPO / "pipelines" / "ci-hills.yaml", tmp_path / "runs", workers=2)
    assert [c.case for c in res.cases] == ["takeoff", "overload", "spray", "gust"]
    batch = json.loads((tmp_path / "runs" / "batch.json").read_text())
    assert batch["pipeline"] == "ci-hills" and batch["passed"] is True
    wj = json.loads((tmp_path / "runs" / "_worlds" / "lidar-hills" / "world.json").read_text())
    assert wj["terrain"]["kind"] == "heightmap" and wj["origin"]["lat"] == 45.29
    assert wj["spawn"]["rest"]["tilt_deg"] < 5.0  # a flat take-off spot on the hillside
    z0, z1 = wj["terrain"]["z_range_enu"]
    assert z1 - z0 > 50.0  # hilly
    for case in batch["cases"]:
        s = json.loads((tmp_path / "runs" / case["run_id"] / "summary.json").read_text())
        failed = [c for c in s["checks"] if not c["passed"]]
        assert s["passed"] and not failed, (case["case"], failed)
        assert len(s["world"]["rows_enu"]) == 6
    spray = json.loads((tmp_path / "runs" / "spray" / "summary.json").read_text())
    assert spray["status"] == "completed"
    assert {c["name"] for c in spray["checks"]} >= {"drain_time", "dose_row_rates", "spray_height"}
