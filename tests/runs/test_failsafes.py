"""Failsafes end to end on the real loop (PyBullet, estimator, built-in autopilot): a gust shoves the
spraying vehicle through the fence; the sprayer goes off at once, summary.json records the failsafe
and every report format (HTML, Markdown, JUnit) states the cause."""

from __future__ import annotations

import json
import logging
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from repo_paths import REPO

from vinecli.runs.failsafes import describe_failsafe

BREACH = """\
name: breach
description: hover 1 m inside the east fence with the sprayer on; a 1-cos gust shoves it out
vehicle: x500-sprayer
tank_fill_l: 1.0
max_duration_s: 20
record_rate_hz: 50
wind: {law: {type: gust, peak_mps: 18.0, start_s: 6.0, duration_s: 4.0, heading_deg: 90.0}}
geofence:
  polygon_enu: [[-10.0, -10.0], [1.0, -10.0], [1.0, 10.0], [-10.0, 10.0]]
  action: hold
phases:
  - {type: takeoff, altitude_agl_m: 4.0}
  - {type: sprayer, flow_lps: 0.02}
  - {type: hold, duration_s: 10.0}
  - {type: land}
checks:
  - {name: completed, quantity: status, op: "==", bound: completed}
"""


@pytest.fixture(scope="module")
def breach_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[logging.LogRecord]]:
    from vinecli.runs import RunRequest, run_mission
    from vinecli.world import build_world

    tmp = tmp_path_factory.mktemp("failsafe")
    world = build_world(REPO / "worlds" / "flat.yaml", tmp / "flat")
    (tmp / "breach.yaml").write_text(BREACH)
    records: list[logging.LogRecord] = []
    handler = logging.Handler()
    handler.emit = records.append  # type: ignore[method-assign]
    logging.getLogger("vinecli").addHandler(handler)
    try:
        s = run_mission(RunRequest(tmp / "breach.yaml", world, tmp / "runs", seed=2))
    finally:
        logging.getLogger("vinecli").removeHandler(handler)
    return Path(s.run_dir), records


def test_failsafe_recorded_and_sprayer_off(breach_run: tuple[Path, list[logging.LogRecord]]) -> None:
    run, records = breach_run
    s = json.loads((run / "summary.json").read_text())
    assert s["status"] == "timeout" and not s["passed"]  # hold until the time limit (PX4 GF_ACTION 2)
    (fs,) = s["failsafes"]
    assert fs["cause"] == "geofence" and fs["action"] == "hold" and 6.0 < fs["t_s"] < 10.0
    assert fs["position_enu"][0] > 0.9 and fs["position_enu"][2] > 3.0  # the truth, at the fence, airborne
    text = describe_failsafe(fs)
    assert text == f"geofence breach at {fs['t_s']:.2f} s → hold; sprayer off"
    assert text in s["status_message"]
    t = pq.read_table(run / "timeseries.parquet")
    ts, cmd = t.column("t_s").to_numpy(), t.column("tank_flow_cmd_lps").to_numpy()
    assert np.all(cmd[(ts > 5.5) & (ts < fs["t_s"] - 0.02)] == pytest.approx(0.02))  # spraying before
    assert np.all(cmd[ts >= fs["t_s"] + 0.02] == 0.0)  # off at once, for the rest of the run
    warnings = [r for r in records if r.levelno >= logging.WARNING and "geofence" in r.getMessage()]
    assert len(warnings) == 1  # one console warning per episode


def test_every_report_format_states_the_failsafe(breach_run: tuple[Path, list[logging.LogRecord]],
                                                 tmp_path: Path) -> None:
    from vinecli.report.assemble import build_report

    run, _ = breach_run
    fs = json.loads((run / "summary.json").read_text())["failsafes"][0]
    text = describe_failsafe(fs)
    build_report(run.parent, tmp_path / "report", formats=["html", "md", "junit", "json"], figures="none")
    html = (tmp_path / "report" / "report.html").read_text()
    assert text in html and "Failsafes" in html
    md = (tmp_path / "report" / "summary.md").read_text()
    assert "### Failsafes" in md and text in md
    failures = [f for f in ET.parse(tmp_path / "report" / "junit.xml").iter("failure")]
    assert failures and all(text in f.get("message", "") for f in failures)
    rep = json.loads((tmp_path / "report" / "summary.json").read_text())
    assert rep["runs"][0]["failsafes"][0]["cause"] == "geofence"
