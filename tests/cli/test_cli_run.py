"""``vinecli run mission|batch`` end to end: real worlds, the real loop and autopilot, real run directories."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml
from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.missions.spec_io import load_mission
from vinecli.sim.row import timeseries_columns

runner = CliRunner()

QUICK = """\
name: quick
description: takeoff to 2 m, hold, land on flat ground
vehicle: x500-sprayer
tank_fill_l: 0.5
max_duration_s: {maxdur}
record_rate_hz: 25
phases:
  - {{type: takeoff, altitude_agl_m: 2.0}}
  - {{type: hold, duration_s: {hold}}}
  - {{type: land}}
checks:
  - {{name: climbed, quantity: metric:altitude_above_home_m, window: ["phase:1", "phase_end:1"], op: between, bound: [1.7, 2.3]}}
  - {{name: too_high, quantity: pos_enu_z_m, reduce: max, op: ">", bound: {high}}}
"""


def quick_mission(d: Path, *, high: float = 1.0, hold: float = 1.0, maxdur: float = 40.0, name: str = "quick.yaml"
                  ) -> Path:
    p = d / name
    p.write_text(QUICK.format(high=high, hold=hold, maxdur=maxdur))
    return p


def test_run_mission_writes_a_complete_run_dir(flat_world_dir: Path, tmp_path: Path) -> None:
    m = quick_mission(tmp_path)
    out = tmp_path / "runs"
    r = runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(out), "--seed", "3",
                            "--mcap", "--rate", "20"])
    assert r.exit_code == 0, r.output
    run = out / "quick-s3"
    assert sorted(p.name for p in run.iterdir()) == sorted([
        "timeseries.parquet", "summary.json", "events.jsonl", "manifest.json", "mission.yaml",
        "terrain_preview.npz", "run.mcap"])
    s = json.loads((run / "summary.json").read_text())
    for key in ("run_id", "case", "mission", "description", "vehicle", "world", "autopilot", "seed", "status",
                "status_message", "passed", "sim_time_s", "failsafes", "checks", "metrics", "timing", "started_utc"):
        assert key in s, key
    assert s["failsafes"] == []
    assert {"wall_time_s", "real_time_factor", "wall_per_step_us", "cpu_per_step_us"} <= set(s["timing"])
    assert not {"wall_time_s", "real_time_factor", "wall_per_step_us", "cpu_per_step_us", "loop_wall_s"} & set(
        s["metrics"]) and "wall_time_s" not in s  # machine-dependent figures only under timing
    assert s["status"] == "completed" and s["passed"] and s["seed"] == 3 and s["vehicle"] == "x500-sprayer"
    assert set(s["world"]) >= {"name", "dir", "origin", "rows_enu", "geofence"}
    assert s["world"]["origin"]["lat"] == pytest.approx(47.397742)
    names = [c["name"] for c in s["checks"]]
    assert names == ["climbed", "too_high", "status"]  # the implicit status check comes last
    climbed = s["checks"][0]
    assert climbed["window"][0] < climbed["window"][1] and 1.7 <= climbed["value"] <= 2.3
    table = pq.read_table(run / "timeseries.parquet")
    assert set(timeseries_columns(4)) <= set(table.column_names)
    t = table.column("t_s").to_numpy()
    dt = np.diff(t)[:-1]  # the last row may be the final state, off the grid
    assert np.mean(dt) == pytest.approx(0.05, abs=1e-3)  # --rate 20 Hz (on the 4 ms physics clock)
    assert np.all(np.abs(dt - 0.05) <= 0.004 + 1e-9)
    assert t[-1] == pytest.approx(s["sim_time_s"], abs=0.06)
    events = [json.loads(line) for line in (run / "events.jsonl").read_text().splitlines()]
    kinds = {e["kind"] for e in events}
    assert {"liftoff", "touchdown", "phase"} <= kinds
    assert all(set(e) == {"t_s", "kind", "message", "data"} for e in events)
    back = load_mission(run / "mission.yaml")
    assert back.record_rate_hz == 20 and back.name == "quick"
    prev = np.load(run / "terrain_preview.npz")
    assert prev["z"].shape == (prev["y"].size, prev["x"].size)
    man = json.loads((run / "manifest.json").read_text())
    assert man["command"] == "run mission" and man["parameters"]["seed"] == 3
    assert {o["path"] for o in man["outputs"]} >= {"summary.json", "timeseries.parquet", "run.mcap"}
    from mcap.reader import make_reader

    with open(run / "run.mcap", "rb") as f:
        reader = make_reader(f)
        topics = [ch.topic for _, ch, _ in reader.iter_messages(topics=["/pose"])]
        assert len(topics) == table.num_rows
        summ = reader.get_summary()
        assert {c.topic for c in summ.channels.values()} == {"/pose", "/state", "/events"}


def test_failing_check_exits_1(flat_world_dir: Path, tmp_path: Path) -> None:
    m = quick_mission(tmp_path, high=50.0)
    r = runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(tmp_path / "runs")])
    assert r.exit_code == 1
    assert "too_high" in r.output and "FAIL" in r.output
    s = json.loads((tmp_path / "runs" / "quick-s0" / "summary.json").read_text())
    assert s["passed"] is False and s["status"] == "completed"


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        (QUICK.format(high=1, hold=1, maxdur=40).replace("altitude_agl_m: 2.0", "altitude_agl_m: -2.0"),
         "phases.0.takeoff.altitude_agl_m"),
        (QUICK.format(high=1, hold=1, maxdur=40).replace("reduce: max", "reduce: median"), "checks.1.reduce"),
        (QUICK.format(high=1, hold=1, maxdur=40).replace('"phase:1"', '"phase"'), "checks.0.window"),
        (QUICK.format(high=1, hold=1, maxdur=40).replace("x500-sprayer", "x900"), "vehicle"),
        ("name: [unclosed\n", "invalid YAML"),
    ],
)
def test_bad_mission_exits_2_naming_file_and_field(flat_world_dir: Path, tmp_path: Path, text: str, needle: str) -> None:
    m = tmp_path / "bad_mission.yaml"
    m.write_text(text)
    out = tmp_path / "runs"
    r = runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(out)])
    assert r.exit_code == 2, r.output
    assert "bad_mission.yaml" in r.output and needle in r.output
    assert "Traceback" not in r.output
    assert not out.exists()


def test_missing_world_exits_2(tmp_path: Path) -> None:
    m = quick_mission(tmp_path)
    r = runner.invoke(app, ["run", "mission", str(m), "--world", str(tmp_path / "nowhere"), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "nowhere" in r.output


def test_interrupted_run_is_a_valid_partial_run(flat_world_dir: Path, tmp_path: Path) -> None:
    from vinecli.runs import RunRequest, run_mission

    m = quick_mission(tmp_path, hold=30.0)
    state = {"t": 0.0}

    def progress(sim_t: float, wall_t: float) -> None:
        state["t"] = sim_t

    s = run_mission(RunRequest(m, flat_world_dir, tmp_path / "runs", seed=1), progress=progress,
                    should_stop=lambda: state["t"] >= 6.0)
    assert s.status == "interrupted" and not s.passed
    assert 6.0 <= s.sim_time_s < 8.0
    run = Path(s.run_dir)
    summ = json.loads((run / "summary.json").read_text())
    assert summ["status"] == "interrupted"
    t = pq.read_table(run / "timeseries.parquet").column("t_s").to_numpy()
    assert t[-1] == pytest.approx(s.sim_time_s, abs=0.05)
    assert (run / "manifest.json").is_file()


def test_run_batch_cli_on_a_small_pipeline(flat_world_dir: Path, tmp_path: Path) -> None:
    quick_mission(tmp_path, name="ok.yaml")
    # idle on the ground for hours (a flight would end within minutes on its battery, seconds of wall time)
    # (recorded at 2 Hz: 10 h at the default 50 Hz could need more memory than a run may use, refused at load)
    (tmp_path / "slow.yaml").write_text("name: slow\nvehicle: x500-sprayer\nmax_duration_s: 36000\nrecord_rate_hz: 2\n"
                                        "phases:\n  - {type: open_loop, duration_s: 36000, rotor_speeds_rad_s: 0}\n")
    bad = yaml.safe_load(QUICK.format(high=50, hold=1, maxdur=40))
    bad["name"] = "fails"
    (tmp_path / "fails.yaml").write_text(yaml.safe_dump(bad))
    broken = tmp_path / "broken_world"
    broken.mkdir()
    (broken / "world.json").write_text('{"schema": "something-else"}')
    pipe = tmp_path / "pipe.yaml"
    pipe.write_text(f"""\
name: small
world: {flat_world_dir}
missions:
  - ok.yaml
  - fails.yaml
  - {{mission: ok.yaml, name: on-broken-world, world: broken_world}}
  - {{mission: slow.yaml, name: slow}}
""")
    out = tmp_path / "runs"
    r = runner.invoke(app, ["run", "batch", str(pipe), "--out", str(out), "--workers", "2", "--timeout", "4"])
    assert r.exit_code == 3, r.output  # a case could not run
    b = json.loads((out / "batch.json").read_text())
    by = {c["case"]: c for c in b["cases"]}
    assert by["quick"]["passed"] and by["quick"]["status"] == "completed"
    assert not by["fails"]["passed"] and by["fails"]["error"] is None and by["fails"]["failed_checks"] == ["too_high"]
    assert by["on-broken-world"]["status"] == "error" and "schema" in by["on-broken-world"]["error"]
    assert by["slow"]["status"] == "error" and "timeout" in by["slow"]["error"]
    assert (out / "quick" / "summary.json").is_file() and (out / "slow" / "summary.json").is_file()
    # resume: the finished cases are skipped, the broken and the timed-out case are tried again
    r2 = runner.invoke(app, ["run", "batch", str(pipe), "--out", str(out), "--resume", "--timeout", "4"])
    assert r2.exit_code == 3
    b2 = json.loads((out / "batch.json").read_text())
    skipped = {c["case"] for c in b2["cases"] if c["skipped"]}
    assert skipped == {"quick", "fails"}


def test_run_batch_bad_pipeline_exits_2(tmp_path: Path) -> None:
    p = tmp_path / "p.yaml"
    p.write_text("name: x\nmissions: [nothing.yaml]\nworld: .\n")
    r = runner.invoke(app, ["run", "batch", str(p), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "p.yaml" in r.output and "nothing.yaml" in r.output


@pytest.mark.parametrize(("signame", "code"), [("SIGINT", 130), ("SIGTERM", 143)])
def test_ctrl_c_keeps_a_partial_run_marked_interrupted(flat_world_dir: Path, tmp_path: Path, monkeypatch,
                                                       signame: str, code: int) -> None:
    """A real SIGINT (Ctrl-C) or SIGTERM (a CI timeout, kill) while the loop runs: the run stops at the next
    step, is written with status interrupted, the CLI exits 128 + the signal number."""
    import os
    import signal

    import vinecli.runs.mission as rm

    sig = getattr(signal, signame)

    m = quick_mission(tmp_path, hold=30.0)
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    real_run = rm.run_mission
    sent = {"t": None}

    def run_and_press_ctrl_c(*args, **kw):
        user_progress = kw.get("progress")

        def progress(sim_t: float, wall_t: float) -> None:
            if user_progress:
                user_progress(sim_t, wall_t)
            if sim_t >= 4.0 and sent["t"] is None:
                sent["t"] = sim_t
                os.kill(os.getpid(), sig)

        kw["progress"] = progress
        return real_run(*args, **kw)

    monkeypatch.setattr("vinecli.runs.run_mission", run_and_press_ctrl_c)
    out = tmp_path / "runs"
    r = runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(out)])
    assert r.exit_code == code, r.output
    s = json.loads((out / "quick-s0" / "summary.json").read_text())
    assert s["status"] == "interrupted" and s["passed"] is False and signame in s["status_message"]
    assert sent["t"] is not None and sent["t"] <= s["sim_time_s"] < sent["t"] + 1.5
    assert pq.read_table(out / "quick-s0" / "timeseries.parquet").num_rows > 50
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before  # handlers restored


def test_recheck_a_finished_run(flat_world_dir: Path, tmp_path: Path) -> None:
    m = quick_mission(tmp_path)
    out = tmp_path / "runs"
    assert runner.invoke(app, ["run", "mission", str(m), "--world", str(flat_world_dir), "--out", str(out)]).exit_code == 0
    run = out / "quick-s0"
    before = {p.name: p.stat().st_mtime_ns for p in run.iterdir()}
    r = runner.invoke(app, ["run", "checks", str(run)])
    assert r.exit_code == 0 and "climbed" in r.output
    stricter = quick_mission(tmp_path, high=2.5, name="stricter.yaml")  # max z > 2.5 m: fails after a 2 m climb
    r = runner.invoke(app, ["run", "checks", str(run), "--mission", str(stricter)])
    assert r.exit_code == 1 and "too_high" in r.output
    assert {p.name: p.stat().st_mtime_ns for p in run.iterdir()} == before  # read-only
    r = runner.invoke(app, ["run", "checks", str(tmp_path)])
    assert r.exit_code == 2 and "summary.json" in r.output
