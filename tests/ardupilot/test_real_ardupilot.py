"""Real ArduCopter SITL (``../shared/ardupilot``, extracted once into a cache dir) flown by vinecli's physics
in lockstep: a short mission end to end through ``run mission``, the run folder audited, twice for
determinism; the firmware killed mid-flight ends the run as an error. Skips only without ``../shared``."""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from pathlib import Path

import pytest

from vinecli.specs.mission import MissionSpec

pytestmark = [pytest.mark.ardupilot, pytest.mark.timeout(600)]

SHORT = {
    "name": "ap-short", "autopilot": "ardupilot", "vehicle": "x500-sprayer", "tank_fill_l": 1.0, "max_duration_s": 40.0,
    "record_rate_hz": 50.0,
    "phases": [{"type": "takeoff", "altitude_agl_m": 3.0, "climb_speed_mps": 1.5},
               {"type": "goto", "position_enu": [4.0, 0.0], "speed_mps": 2.0},
               {"type": "land", "descent_speed_mps": 0.7}],
    "checks": [{"name": "height", "quantity": "height_agl_m", "reduce": "max", "op": "between", "bound": [2.6, 3.6]},
               {"name": "landed", "quantity": "on_ground", "reduce": "final", "op": "==", "bound": 1}],
}


def _fly(ardupilot_bin: Path, world: Path, out: Path, run_id: str) -> dict:
    from vinecli.runs import run_mission

    run_mission(MissionSpec.model_validate(SHORT), world, out, seed=3, run_id=run_id,
                autopilot_options={"ardupilot_bin": str(ardupilot_bin)})
    return json.loads((out / run_id / "summary.json").read_text())


@pytest.fixture(scope="module")
def two_flights(ardupilot_bin: Path, flat_world_dir: Path, tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("ap-runs")
    return [_fly(ardupilot_bin, flat_world_dir, out, f"short-{k}") for k in range(2)], out


def test_arducopter_flies_the_mission_and_the_run_folder_says_so(two_flights, ardupilot_bin):
    (s, _), out = two_flights[0], two_flights[1]
    s = two_flights[0][0]
    assert s["status"] == "completed" and s["passed"], (s["status_message"], [c for c in s["checks"] if not c["passed"]])
    fw = s["firmware"]
    assert s["autopilot"] == "ardupilot" and fw["firmware"] == "ArduCopter"
    assert fw["version"] == "4.7.0-dev" and len(fw["git_hash"]) == 8 and len(fw["sha256"]) == 64
    m = s["metrics"]
    assert m["ardupilot_stalls"] == 0 and m["ardupilot_lockstep_steps"] > 1000 and 20.0 < m["ardupilot_boot_s"] < 90.0
    run = out / "short-0"
    names = {Path(f).name for f in fw["files"]}
    assert {"vinecli.parm", "ardupilot.log"} <= names and any(n.endswith(".BIN") for n in names)
    manifest = json.loads((run / "manifest.json").read_text())
    listed = json.dumps(manifest)
    assert all(Path(f).name in listed for f in fw["files"])
    events = [json.loads(x) for x in (run / "events.jsonl").read_text().splitlines()]
    kinds = [e["kind"] for e in events]
    assert "ardupilot_params" in kinds and "mission_uploaded" in kinds and "firmware" in kinds
    reached = [e["data"]["seq"] for e in events if e["kind"] == "mission_item_reached"]
    assert reached and max(reached) == 3  # home slot 0, takeoff 1, waypoint 2, land 3
    parm = (run / "firmware" / "vinecli.parm").read_text()
    assert "SCHED_LOOP_RATE 250" in parm and "FRAME_CLASS 1" in parm


def test_two_runs_of_a_seed_are_the_same_flight(two_flights):
    out = two_flights[1]
    from vinecli.runs.rundir import read_timeseries

    a = read_timeseries(out / "short-0" / "timeseries.parquet")
    b = read_timeseries(out / "short-1" / "timeseries.parquet")
    assert len(a["t_s"]) == len(b["t_s"])
    for col in ("pos_enu_x_m", "pos_enu_z_m", "rotor1_cmd_radps", "tank_flow_lps", "battery_voltage_v"):
        assert (a[col] == b[col]).all(), col


def test_killing_arducopter_mid_flight_is_an_error_and_the_batch_goes_on(ardupilot_bin, flat_world_dir, tmp_path):
    """SIGKILL the firmware a few seconds after it armed: that case ends ``error`` with the cause (exit 3 in
    the batch), the other case still flies."""
    import yaml

    from vinecli.batch import run_batch

    mission = tmp_path / "short.yaml"
    mission.write_text(yaml.safe_dump(SHORT))
    pipe = tmp_path / "pipe.yaml"
    pipe.write_text(yaml.safe_dump({"name": "kill", "world": str(flat_world_dir), "timeout_s": 300,
                                    "missions": [{"mission": "short.yaml", "name": "victim"},
                                                 {"mission": "short.yaml", "name": "survivor", "seed": 5}]}))
    killed: list[int] = []

    def killer() -> None:  # the first ArduPilot this test started, once it ran 3 s, gets SIGKILL
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline and not killed:
            for pid in _our_arducopters():
                if _age_s(pid) > 3.0:
                    os.kill(pid, signal.SIGKILL)
                    killed.append(pid)
                    return
            time.sleep(0.1)

    th = threading.Thread(target=killer, daemon=True)
    th.start()
    res = run_batch(pipe, tmp_path / "runs", jobs=1, ardupilot_bin=ardupilot_bin)
    th.join(5)
    by = {c.case: c for c in res.cases}
    assert killed, "no ArduPilot was killed"
    assert by["victim"].status == "error" and by["victim"].error and "ArduPilot exited" in by["victim"].error, by["victim"]
    assert by["survivor"].status == "completed" and by["survivor"].passed
    assert res.n_errors == 1 and res.n_failed == 0


def _ppid(pid: int) -> int:
    return int((Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[1])


def _our_arducopters() -> list[int]:
    """arducopter processes started below this test process (never another session's)."""
    me, found = os.getpid(), []
    for p in Path("/proc").iterdir():
        if not p.name.isdigit():
            continue
        try:
            if (p / "comm").read_text().strip() != "arducopter":
                continue
            pid = int(p.name)
            while pid > 1 and pid != me:
                pid = _ppid(pid)
            if pid == me:
                found.append(int(p.name))
        except OSError:
            continue
    return found


def _age_s(pid: int) -> float:
    try:
        start = float((Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[19])
        return float(Path("/proc/uptime").read_text().split()[0]) - start / os.sysconf("SC_CLK_TCK")
    except OSError:
        return 0.0
