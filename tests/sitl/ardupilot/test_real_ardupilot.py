"""The CI gate flown by real ArduCopter SITL (``../shared/ardupilot``, extracted once into a cache dir),
vinecli's physics answering its JSON servo frames in lockstep; skips only without ``../shared``.

pipelines/ci-ardupilot.yaml (takeoff, spray with AC_Sprayer driving the pump, gust) must pass every check
with the run folders audited (firmware identity, kept logs, parameters read back, stalls 0, the battery
ArduPilot logged is the simulated pack); a second flight of a case is the same flight to the bit; the
firmware killed mid-run ends its case as an error and the batch goes on.
"""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from tests.repo_paths import REPO
from vinecli.runs.rundir import read_timeseries

pytestmark = [pytest.mark.ardupilot, pytest.mark.timeout(900)]


@pytest.fixture(scope="module")
def ci_ardupilot(ardupilot_bin: Path, sample_world_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, Path]:
    """pipelines/ci-ardupilot.yaml run once with --workers 2 (three ArduPilot processes, two at a time), on its
    world as the session built it (``sample_world_dir``)."""
    from vinecli.batch import run_batch

    out = tmp_path_factory.mktemp("ci-ardupilot")
    return run_batch(REPO / "pipelines" / "ci-ardupilot.yaml", out, workers=2, world=sample_world_dir,
                     ardupilot_bin=ardupilot_bin), out


def _summary(out: Path, case: str) -> dict[str, Any]:
    return json.loads((out / case / "summary.json").read_text())


def test_ci_ardupilot_passes_every_check_and_the_runs_are_audited(ci_ardupilot, ardupilot_bin):
    result, out = ci_ardupilot
    assert {c.case for c in result.cases} == {"takeoff", "spray-rows", "gust"}
    for c in result.cases:
        s = _summary(out, c.case)
        failed = [(k["name"], k["value"], k["bound"]) for k in s["checks"] if not k["passed"]]
        assert c.passed and c.error is None, (c.case, c.status, failed, c.error)
        fw = s["firmware"]
        assert s["autopilot"] == "ardupilot" and fw["firmware"] == "ArduCopter" and fw["version"] == "4.7.0-dev"
        assert len(fw["git_hash"]) == 8 and fw["binary"] == str(ardupilot_bin.resolve()) and len(fw["sha256"]) == 64
        m = s["metrics"]
        assert m["ardupilot_stalls"] == 0 and m["ardupilot_lockstep_steps"] > 1000 and 20 < m["ardupilot_boot_s"] < 90
        assert m["ardupilot_battery_warnings"] == 0 and m["ardupilot_late_markers"] == 0  # every marker answered
        assert any(k["name"] == "ardupilot_stalls" and k.get("implicit") for k in s["checks"])  # a stall fails the run
        names = {Path(f).name for f in fw["files"]}
        assert {"vinecli.parm", "ardupilot.log"} <= names and any(n.endswith(".BIN") for n in names)
        # stopped by SIGTERM, its clock moved on so that it could act on it: it exited by itself, its log closed
        # (a frame left unanswered held it until the SIGKILL 3 s later)
        assert "Exitting" in (out / c.case / "firmware" / "ardupilot.log").read_text()
        listed = json.dumps(json.loads((out / c.case / "manifest.json").read_text()))
        assert all(Path(f).name in listed for f in fw["files"])  # the kept files are in the manifest
        kinds = {e["kind"] for e in _events(out / c.case)}
        assert {"ardupilot_params", "ardupilot_ready", "mission_uploaded", "firmware"} <= kinds
    alt = next(k for k in _summary(out, "takeoff")["checks"] if k["name"] == "altitude_reached")
    assert abs(alt["value"] - 8.0) <= 0.3


def _events(run: Path) -> list[dict[str, Any]]:
    return [json.loads(x) for x in (run / "events.jsonl").read_text().splitlines()]


def test_the_pump_follows_arducopters_sprayer(ci_ardupilot):
    """AC_Sprayer drives the pump: SPRAY_ENABLE with the pump on servo function 22, and while it sprays the
    flow is proportional to ground speed (the asked litres per metre), so >= 90 % of the rows are covered."""
    _, out = ci_ardupilot
    s = _summary(out, "spray-rows")
    assert s["metrics"]["row_coverage_fraction"] >= 0.9
    parm = (out / "spray-rows" / "firmware" / "vinecli.parm").read_text()
    assert "SPRAY_ENABLE 1\n" in parm and "SERVO9_FUNCTION 22\n" in parm
    ts = read_timeseries(out / "spray-rows" / "timeseries.parquet")
    flow = ts["tank_flow_cmd_lps"]
    speed = np.hypot(ts["vel_enu_x_mps"], ts["vel_enu_y_mps"])
    # at a steady ground speed: while the vehicle speeds up in a pass's run-in AC_Sprayer follows its EKF's
    # speed, which lags the true one by the estimator's delay
    steady = np.abs(np.gradient(speed, ts["t_s"])) < 0.2
    on = (flow > 0) & (speed > 1.0) & steady
    per_m = flow[on] / speed[on]
    asked = 0.1 * float(parm.split("SPRAY_PUMP_RATE ")[1].split()[0]) / 100.0  # L/s per m/s at full pump 0.1 L/s
    assert on.sum() > 2000 and abs(np.median(per_m) / asked - 1.0) < 0.02
    assert np.percentile(per_m, 95) / np.percentile(per_m, 5) < 1.05
    # the pump output goes through the pump model: at each switch-on the delivered flow lags the command by
    # its first-order lag (tau_up 0.3 s: 63 % after tau), the tank drains what is delivered
    t, q = ts["t_s"], ts["tank_flow_lps"]
    starts = [(i, int(np.searchsorted(t, t[i] + 0.3))) for i in np.flatnonzero((flow[1:] > 0) & (flow[:-1] == 0)) + 1]
    starts = [(i, k) for i, k in starts if k < len(t) and flow[i:k + 1].min() > 0]  # on for 0.3 s at least
    assert len(starts) >= 3  # one per pass
    for i, k in starts:
        assert q[i] < 0.5 * flow[i] and 0.5 * flow[k] < q[k] < 0.8 * flow[k], (t[i], q[i], q[k], flow[k])
    assert "SPRAY_SPEED_MIN 100\n" in parm  # the sprayer's control.speed_min_mps, 1 m/s


def test_the_battery_arducopter_logged_is_the_simulated_pack(ci_ardupilot):
    """ArduPilot's own dataflash log (BAT: voltage, current) against vinecli's pack at the same times."""
    from pymavlink import mavutil

    _, out = ci_ardupilot
    s = _summary(out, "gust")
    boot = s["metrics"]["ardupilot_boot_s"]
    log = next((out / "gust" / "firmware").glob("*.BIN"))
    reader = mavutil.mavlink_connection(str(log))
    bat = []
    while (m := reader.recv_match(type="BAT")) is not None:
        bat.append((m.TimeUS * 1e-6 - boot, m.Volt, m.Curr))
    ts = read_timeseries(out / "gust" / "timeseries.parquet")
    flying = [(t, v, i) for t, v, i in bat if 5.0 < t < ts["t_s"][-1] - 5.0]
    assert len(flying) > 100
    dv = [abs(v - np.interp(t, ts["t_s"], ts["battery_voltage_v"])) for t, v, _ in flying]
    di = [abs(i - np.interp(t, ts["t_s"], ts["battery_current_a"])) for t, _, i in flying]
    assert np.median(dv) < 0.02 and max(dv) < 0.2  # 0.1 s feed interval
    assert np.median(di) < 0.05 * np.median(ts["battery_current_a"]) and min(v for _, v, _ in flying) > 13.0


def test_compared_with_the_builtin_beside_a_cpu_hog_it_is_the_same_flight(ci_ardupilot, ardupilot_bin, sample_world_dir,
                                                                          tmp_path):
    """``run compare`` of the takeoff case (built-in vs ArduPilot, the batch's seed) beside twice as many busy
    processes as CPUs: the ArduPilot run is the batch's flight to the bit (lockstep: the load changes nothing),
    and the comparison (table, figure, report section) is written."""
    from tests.cpu_hog import cpu_hog
    from vinecli.batch.compare_autopilots import compare_autopilots
    from vinecli.report import build_report

    result, out = ci_ardupilot
    case = next(c for c in result.cases if c.case == "takeoff")
    with cpu_hog(2.0):
        res, cmp = compare_autopilots(REPO / "pipelines" / "missions" / "takeoff.yaml", sample_world_dir,
                                      tmp_path / "cmp", autopilots=("builtin", "ardupilot"), seed=case.seed, workers=2,
                                      ardupilot_bin=ardupilot_bin)
    assert res.passed and cmp is not None
    runs = (out / "takeoff", tmp_path / "cmp" / "takeoff-ardupilot")
    counters = [{k: v for k, v in _summary(r.parent, r.name)["metrics"].items() if k.startswith("ardupilot_")}
                for r in runs]
    for m in counters:  # what the lockstep guarantees rests on: every marker answered, every byte delivered
        assert m["ardupilot_stalls"] == 0 and m["ardupilot_late_markers"] == 0 and m["ardupilot_undelivered"] == 0, m
    a, b = (read_timeseries(r / "timeseries.parquet") for r in runs)
    assert len(a["t_s"]) == len(b["t_s"]), counters
    for col in ("pos_enu_x_m", "pos_enu_z_m", "rotor1_cmd_radps", "tank_flow_lps", "battery_voltage_v"):
        differ = np.flatnonzero(a[col] != b[col])
        where = f"first at t = {a['t_s'][differ[0]]} s (row {differ[0]})" if differ.size else ""
        assert differ.size == 0, (col, where, counters)  # the firmware's own logs (firmware/*.BIN) show where
    by = {r["autopilot"]: r for r in cmp["runs"]}
    assert set(by) == {"builtin", "ardupilot"} and by["ardupilot"]["firmware"].startswith("ArduCopter 4.7.0")
    for r in by.values():
        assert r["status"] == "completed" and 10 < r["mission_time_s"] < 40 and 0 < r["energy_wh"] < 10
    assert (tmp_path / "cmp" / "comparison.json").is_file() and (tmp_path / "cmp" / "comparison.png").stat().st_size > 10_000
    rep = build_report(tmp_path / "cmp", tmp_path / "report", formats="html,md,json")
    md = (tmp_path / "report" / "summary.md").read_text()
    assert "## Autopilots side by side" in md and "ArduCopter 4.7.0-dev" in md
    assert "figA" in (tmp_path / "report" / "report.html").read_text() and rep.exit_code == 0


SHORT = {"name": "ap-short", "vehicle": "x500-sprayer", "max_duration_s": 30.0, "record_rate_hz": 20.0,
         "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "hold", "duration_s": 1.0},
                    {"type": "land"}]}


def test_killing_arducopter_mid_run_is_an_error_and_the_batch_goes_on(ardupilot_bin, flat_world_dir, tmp_path):
    """SIGKILL the first case's ArduPilot in flight (2 s of wall time after it armed, seen on its second
    MAVLink port): that case ends ``error`` naming the cause (exit 3 for the batch), the second case still
    flies to its end."""
    from vinecli.batch import run_batch

    (tmp_path / "short.yaml").write_text(yaml.safe_dump(SHORT))
    # the victim hovers 30 s: at ~3x real time the short mission was over before a kill 2 s after arming landed
    long_hold = {**SHORT, "max_duration_s": 90.0,
                 "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "hold", "duration_s": 30.0},
                            {"type": "land"}]}
    (tmp_path / "long.yaml").write_text(yaml.safe_dump(long_hold))
    pipe = tmp_path / "pipe.yaml"
    pipe.write_text(yaml.safe_dump({"name": "kill", "world": str(flat_world_dir), "autopilot": "ardupilot",
                                    "timeout_s": 300, "missions": [{"mission": "long.yaml", "name": "victim"},
                                                                   {"mission": "short.yaml", "name": "survivor"}]}))
    killed: list[int] = []

    def killer() -> None:  # watch this test's ArduPilot on its SERIAL1 (TCP 5762 + 10 i): SIGKILL 2 s after it armed
        from pymavlink import mavutil

        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and not killed:
            pids = _our_arducopters()
            if not pids:
                time.sleep(0.2)
                continue
            pid = pids[0]
            argv = (Path("/proc") / str(pid) / "cmdline").read_bytes().split(b"\0")
            port = 5762 + 10 * int(argv[argv.index(b"-I") + 1])
            try:
                gcs = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=254, retries=20)
            except OSError:
                continue
            armed_at = None
            while time.monotonic() < deadline and not killed:
                hb = gcs.recv_match(type="HEARTBEAT", blocking=True, timeout=1.0)
                if hb is not None and hb.get_srcComponent() == 1 and hb.base_mode & 128 and armed_at is None:
                    armed_at = time.monotonic()
                if armed_at is not None and time.monotonic() - armed_at > 2.0:
                    os.kill(pid, signal.SIGKILL)
                    killed.append(pid)
            gcs.close()

    th = threading.Thread(target=killer, daemon=True)
    th.start()
    res = run_batch(pipe, tmp_path / "runs", workers=1, ardupilot_bin=ardupilot_bin)
    th.join(5)
    by = {c.case: c for c in res.cases}
    assert killed, "no ArduPilot was killed"
    assert by["victim"].status == "error" and by["victim"].sim_time_s > 0, by["victim"]
    assert "ArduPilot exited (killed by SIGKILL) at " in (by["victim"].error or ""), by["victim"]
    assert by["survivor"].status == "completed" and by["survivor"].passed, by["survivor"]
    assert res.n_errors == 1 and res.n_failed == 0
    assert not [p for p in _our_arducopters() if p not in killed]  # nothing left running


def _ppid(pid: int) -> int:
    return int((Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[1])


def _our_arducopters() -> list[int]:
    """Live arducopter processes started below this test process (never another session's)."""
    me, found = os.getpid(), []
    for p in Path("/proc").iterdir():
        if not p.name.isdigit():
            continue
        try:
            stat = (p / "stat").read_text().rsplit(")", 1)[1].split()
            if (p / "comm").read_text().strip() != "arducopter" or stat[0] == "Z":
                continue
            pid = int(p.name)
            while pid > 1 and pid != me:
                pid = _ppid(pid)
            if pid == me:
                found.append(int(p.name))
        except (OSError, ValueError):
            continue
    return found


def test_sigterm_while_arducopter_boots_ends_the_run_cleanly(ardupilot_bin, flat_world_dir, tmp_path):
    """SIGTERM to ``vinecli run mission`` while ArduPilot boots: the run stops within seconds (the boot polls
    the stop flag), is written ``interrupted``, the command exits 143 and no ArduPilot is left running."""
    import subprocess
    import sys

    (tmp_path / "short.yaml").write_text(yaml.safe_dump({**SHORT, "autopilot": "ardupilot"}))
    proc = subprocess.Popen([sys.executable, "-m", "vinecli", "run", "mission", str(tmp_path / "short.yaml"),
                             "--world", str(flat_world_dir), "--out", str(tmp_path / "runs"),
                             "--ardupilot-bin", str(ardupilot_bin)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not _our_arducopters():
        time.sleep(0.1)
    started = _our_arducopters()
    assert started, "ArduPilot did not start"
    # inside its boot: ArduPilot takes >= 1.6 s of wall time for the 42 s of its clock it needs (measured on an idle
    # machine, where 2 s after its start it was flying)
    time.sleep(0.5)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 143, out.decode(errors="replace")[-2000:]
    assert time.monotonic() - t0 < 20
    s = json.loads((tmp_path / "runs" / "ap-short-s0" / "summary.json").read_text())
    assert s["status"] == "interrupted" and "SIGTERM" in s["status_message"]
    assert not [pid for pid in started if Path(f"/proc/{pid}").exists()]  # stopped, not orphaned
