"""Every firmware run ends, promptly, and leaves no process.

* class 4: an ``--ardupilot-bin`` that writes garbage on ArduPilot's ports ends with a clear error within the
  frame timeout (it ran past 120 s), and SIGTERM during a hung firmware run ends it in seconds;
* class 5: a ``#!/bin/sh`` wrapper that starts the firmware without ``exec`` leaves nothing behind, after a normal
  end, a SIGTERM or ``kill -9`` of vinecli (the firmware runs in its own process group; the group's lifeline
  kills it when vinecli dies); with the real ArduCopter when ``../shared`` has it;
* class 11: a ``land`` from 400 m does not time out (its timeout scales with the height); a real PX4's 2 m hop, which
  reports take-off and landing but never "in air", ends when PX4 has landed and disarmed, not at ``max_duration_s``
  (PX4's link and early landings: tests/sitl/px4/test_px4_link_garbage.py).
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from attack_kit import kill_session, vinecli_proc, wait_for
from proc_tree import alive, descendants

from tests.sitl.ardupilot.real_ardupilot import ardupilot_bin  # noqa: F401 - fixture
from tests.sitl.px4.real_px4 import px4_bin  # noqa: F401 - fixture

HOLD = {"name": "hold", "vehicle": "x500-sprayer", "max_duration_s": 3600.0, "record_rate_hz": 2.0,
        "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "hold", "duration_s": 3500.0},
                   {"type": "land"}]}

#: an ArduPilot that sends garbage to the servo-frame port and nothing else, for ever
GARBAGE_ARDUPILOT = f"#!{sys.executable}\n" + """import socket, sys, time
i = int(sys.argv[sys.argv.index("-I") + 1])
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
print("garbage ardupilot", flush=True)
while True:
    s.sendto(bytes(range(200)), ("127.0.0.1", 9002 + 10 * i))
    time.sleep(0.001)
"""


def _script(path: Path, text: str) -> Path:
    path.write_text(text)
    path.chmod(0o755)
    return path


def _mission(d: Path, doc: dict = HOLD) -> Path:
    p = d / f"{doc['name']}.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


def _named(pids: set[int], word: str) -> set[int]:
    out = set()
    for p in pids:
        with contextlib.suppress(OSError):
            if word in Path(f"/proc/{p}/cmdline").read_bytes().decode(errors="replace"):
                out.add(p)
    return out


def _kill_all(pids: set[int]) -> None:
    for p in pids:
        with contextlib.suppress(ProcessLookupError):
            os.kill(p, signal.SIGKILL)


def test_garbage_on_ardupilot_s_port_ends_with_a_clear_error(flat_world_dir: Path, tmp_path: Path) -> None:
    fake = _script(tmp_path / "arducopter", GARBAGE_ARDUPILOT)
    t0 = time.monotonic()
    proc = vinecli_proc("run", "mission", _mission(tmp_path), "--world", flat_world_dir, "--out", tmp_path / "runs",
                        "--autopilot", "ardupilot", "--ardupilot-bin", fake)
    try:
        _, err = proc.communicate(timeout=150)
    finally:
        kill_session(proc)
    took = time.monotonic() - t0
    assert proc.returncode == 3, err
    assert "not servo frames" in err and took < 90, (took, err)
    summary = json.loads((tmp_path / "runs" / "hold-s0" / "summary.json").read_text())
    assert summary["status"] == "error" and "firmware/ardupilot.log" in summary["firmware"]["files"]


def test_sigterm_ends_a_hung_firmware_run_in_seconds(flat_world_dir: Path, tmp_path: Path) -> None:
    fake = _script(tmp_path / "arducopter", GARBAGE_ARDUPILOT)
    proc = vinecli_proc("run", "mission", _mission(tmp_path), "--world", flat_world_dir, "--out", tmp_path / "runs",
                        "--autopilot", "ardupilot", "--ardupilot-bin", fake)
    tree: set[int] = set()
    try:
        assert wait_for(lambda: bool(_named(descendants(proc.pid), "arducopter")) or proc.poll() is not None, 120)
        time.sleep(3.0)  # waiting on the firmware's frames
        assert proc.poll() is None
        tree = descendants(proc.pid)
        proc.send_signal(signal.SIGTERM)
        t0 = time.monotonic()
        _, err = proc.communicate(timeout=60)
        took = time.monotonic() - t0
    finally:
        kill_session(proc)
        _kill_all(tree)
    assert proc.returncode == 143 and took < 10, (took, err)
    assert wait_for(lambda: not any(alive(p) for p in tree), 5.0)


WRAPPER = "#!/bin/sh\nexport VINECLI_WRAPPED=1\n{exe} \"$@\"\necho wrapper done\n"  # no exec: the shell stays


@pytest.mark.parametrize("ending", ["SIGTERM", "kill -9"])
def test_a_wrapper_without_exec_leaves_no_firmware(flat_world_dir: Path, tmp_path: Path, ending: str) -> None:
    """The wrapper runs a stand-in firmware (``sleep``) without ``exec``: the death signal reaches the wrapper only."""
    stand_in = f"{sys.executable} -c 'import time; time.sleep(600)' arducopter-fake"
    wrapper = _script(tmp_path / "arducopter", WRAPPER.format(exe=stand_in))
    proc = vinecli_proc("run", "mission", _mission(tmp_path), "--world", flat_world_dir, "--out", tmp_path / "runs",
                        "--autopilot", "ardupilot", "--ardupilot-bin", wrapper)
    firmware: set[int] = set()
    try:
        assert wait_for(lambda: bool(_named(descendants(proc.pid), "arducopter-fake")) or proc.poll() is not None, 120)
        firmware = _named(descendants(proc.pid), "arducopter-fake") | _named(descendants(proc.pid), "/bin/sh")
        assert firmware, "no firmware started"
        os.kill(proc.pid, signal.SIGTERM if ending == "SIGTERM" else signal.SIGKILL)
        proc.wait(timeout=60)
        gone = wait_for(lambda: not any(alive(p) for p in firmware), 5.0, every=0.05)
        assert gone, f"left after {ending} of vinecli: {[p for p in firmware if alive(p)]}"
    finally:
        kill_session(proc)
        _kill_all(firmware)


def test_a_wrapper_around_the_real_arducopter_leaves_nothing(ardupilot_bin: Path, flat_world_dir: Path,  # noqa: F811
                                                             tmp_path: Path) -> None:
    root = tmp_path / "wrapped"
    (root / "bin").mkdir(parents=True)
    defaults = Path(ardupilot_bin).resolve().parent.parent / "defaults"
    if defaults.is_dir():
        os.symlink(defaults, root / "defaults")
    wrapper = _script(root / "bin" / "arducopter", WRAPPER.format(exe=Path(ardupilot_bin).resolve()))
    doc = {**HOLD, "name": "short", "max_duration_s": 120.0,
           "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "land"}]}
    r = subprocess.run([sys.executable, "-m", "vinecli", "run", "mission", str(_mission(tmp_path, doc)), "--world",
                        str(flat_world_dir), "--out", str(tmp_path / "runs"), "--autopilot", "ardupilot",
                        "--ardupilot-bin", str(wrapper)], capture_output=True, text=True, timeout=600,
                       env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])})
    assert r.returncode in (0, 1), r.stderr
    time.sleep(0.5)
    mine = subprocess.run(["pgrep", "-f", str(tmp_path)], capture_output=True, text=True).stdout.split()
    assert mine == [], f"left after the run: {mine}"
    proc = vinecli_proc("run", "mission", _mission(tmp_path), "--world", flat_world_dir, "--out", tmp_path / "runs2",
                        "--autopilot", "ardupilot", "--ardupilot-bin", wrapper)
    tree: set[int] = set()
    try:
        real = str(Path(ardupilot_bin).resolve())
        assert wait_for(lambda: bool(_named(descendants(proc.pid), real)) or proc.poll() is not None, 180)
        time.sleep(3.0)
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
        tree = descendants(proc.pid)
        assert _named(tree, real) and _named(tree, str(wrapper))  # the wrapper's shell and the firmware it started
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        assert wait_for(lambda: not any(alive(p) for p in tree), 5.0, every=0.05), \
            f"left after kill -9: {[p for p in tree if alive(p)]}"
    finally:
        kill_session(proc)
        _kill_all(tree)


def test_a_land_from_400_m_does_not_time_out(flat_world_dir: Path, tmp_path: Path) -> None:
    from vinecli.runs import run_mission
    from vinecli.runs.request import RunRequest

    doc = {"name": "high", "vehicle": "x500-sprayer", "max_duration_s": 1200.0, "record_rate_hz": 1.0,
           "geofence": {"max_altitude_agl_m": 500.0},
           "phases": [{"type": "takeoff", "altitude_agl_m": 400.0}, {"type": "land"}]}
    s = run_mission(RunRequest(mission=_mission(tmp_path, doc), world_dir=flat_world_dir, runs_dir=tmp_path / "runs"))
    assert s.status == "completed", s.status_message  # 571 s of descent at 0.7 m/s: more than the 60 s margin


def test_a_px4_hop_that_is_never_in_air_ends_when_it_has_landed(px4_bin: Path, flat_world_dir: Path,  # noqa: F811
                                                                tmp_path: Path) -> None:
    doc = {"name": "hop", "vehicle": "x500-sprayer", "max_duration_s": 120.0, "record_rate_hz": 2.0,
           "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "land"}]}
    r = subprocess.run([sys.executable, "-m", "vinecli", "run", "mission", str(_mission(tmp_path, doc)), "--world",
                        str(flat_world_dir), "--out", str(tmp_path / "runs"), "--autopilot", "px4", "--px4-bin",
                        str(px4_bin)], capture_output=True, text=True, timeout=900,
                       env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])})
    summary = json.loads((tmp_path / "runs" / "hop-s0" / "summary.json").read_text())
    assert summary["status"] == "completed", (summary["status_message"], r.stderr[-1000:])
    assert summary["sim_time_s"] < 60.0  # it timed out at 120 s, waiting for an "in air" PX4 never reported
