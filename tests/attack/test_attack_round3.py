"""The third attack pass, re-run as a new user would run it, on one sandbox. One attack per
class (the focused tests, several instances each, are in tests/safety, tests/flightlog, tests/sitl/px4 and
tests/rows); every refused command exits 2 with one line, no traceback, and afterwards the sandbox holds no
temporary file or folder, no lock and no folder a failed command made, and no process is left.

1 nesting, 2 a log's clock, 3 early firmware failures, 4 a firmware that speaks garbage, 5 a wrapper without exec,
6 two writers of one file, 7 SIGTERM twice, 8 parents of a failed output, 9 sizes, 10 the wrong line,
11 garbage on PX4's link (tests/sitl/px4/test_px4_link_garbage.py: the fake PX4 is a test fixture), 12 a young crop.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "safety"))
from attack_kit import IDLE, PLAN, cli, error_line, kill_session, mission, vinecli_proc, wait_for  # noqa: E402
from proc_tree import alive, descendants  # noqa: E402
from repo_paths import REPO  # noqa: E402

from tests.flightlog.synthetic_log import synthetic_log  # noqa: E402
from tests.gis.test_gis_world import grower_world  # noqa: E402
from tests.identify.ulog_edit import shifted  # noqa: E402
from tests.rows.row_fields import YoungCrop  # noqa: E402

SPRAY = {"name": "m", "vehicle": "x500-sprayer", "max_duration_s": 60,
         "phases": [{"type": "takeoff", "altitude_agl_m": 2.5},
                    {"type": "spray", "rows": [[[-6.0, -1.0], [6.0, -1.0]]], "height_agl_m": 2.0, "speed_mps": 3.0,
                     "rate_lpha": 60.0},
                    {"type": "land"}]}
TAKEOFF = {"name": "fw", "vehicle": "x500-sprayer", "max_duration_s": 600.0, "record_rate_hz": 2.0,
           "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "hold", "duration_s": 500.0},
                      {"type": "land"}]}


def _env(tmpdir: Path) -> dict[str, str]:
    return {**os.environ, "TMPDIR": str(tmpdir), "COLUMNS": "200",
            "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _run(*args: object, tmpdir: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "vinecli", *map(str, args)], env=_env(tmpdir), capture_output=True,
                          text=True, timeout=timeout)


def _script(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    path.chmod(0o755)
    return path


def _litter(root: Path) -> list[str]:
    """Temporary siblings, locks and scratch folders anywhere under ``root``."""
    return sorted(str(p.relative_to(root)) for p in root.rglob("*")
                  if ".tmp-" in p.name or ".old-" in p.name or p.name.endswith(".lock")
                  or (p.name.startswith("vinecli-") and "." in p.name))


@pytest.fixture(scope="module")
def sandbox(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from vinecli.flightlog.ulog_write import write_ulog

    sb = tmp_path_factory.mktemp("attack3")
    (sb / "tmp").mkdir()
    grower = sb / "grower"
    grower.mkdir()
    grower_world(grower)
    (sb / "m.yaml").write_text(yaml.safe_dump(SPRAY))
    for args in (["world", "build", grower / "w.yaml", "--out", sb / "world"],
                 ["run", "mission", sb / "m.yaml", "--world", sb / "world", "--out", sb / "runs"]):
        r = cli(*args)
        assert r.exit_code in (0, 1), (args, r.output)
    write_ulog(synthetic_log(duration_s=60.0), sb / "flight.ulg")
    return sb


def test_bad_inputs_are_one_line_and_leave_nothing(sandbox: Path) -> None:
    sb, g = sandbox, sandbox / "grower"
    deep = sb / "deep.plan"
    deep.write_text('{"fileType": "Plan", "mission": ' + "[" * 200_000 + "]" * 200_000 + "}")  # class 1
    plan = json.loads(PLAN.read_text())
    plan["mission"]["items"] = plan["mission"]["items"][:2] + [plan["mission"]["items"][2]] * 20_000
    (sb / "many.plan").write_text(json.dumps(plan))  # class 9
    (g / "dir.geojson").mkdir()  # class 10
    spec = yaml.safe_load((g / "w.yaml").read_text())
    (g / "dir.yaml").write_text(yaml.safe_dump({**spec, "gis": {**spec["gis"], "fence": {"path": "dir.geojson"}}}))
    (g / "gone.yaml").write_text(yaml.safe_dump({**spec, "gis": {**spec["gis"], "rows": {"path": "gone.gpkg"}}}))
    attacks = [
        (["plan", "import", deep, "--world", sb / "world", "--out", sb / "deep.yaml"], "nested too deeply"),
        (["plan", "import", sb / "many.plan", "--world", sb / "world", "--out", sb / "many.yaml"], "at most 10,000"),
        (["world", "build", g / "dir.yaml", "--out", sb / "w2"], "is a directory"),
        (["world", "build", g / "gone.yaml", "--out", sb / "new" / "a" / "b" / "w"], "gone.gpkg"),  # class 8
        (["run", "mission", sb / "m.yaml", "--world", sb / "world", "--out", sb / "r2", "--autopilot", "ardupilot",
          "--ardupilot-bin", g], "is a directory"),
    ]
    for args, phrase in attacks:
        r = cli(*args)
        assert r.exit_code == 2, (args, r.output)
        assert phrase in error_line(r), (args, r.stderr)
    assert not (sb / "new").exists() and not (sb / "w2").exists() and not (sb / "r2").exists()
    assert _litter(sb) == []


def test_a_log_with_a_jump_is_fitted_in_seconds(sandbox: Path) -> None:  # class 2
    (sandbox / "jump.ulg").write_bytes(shifted((sandbox / "flight.ulg").read_bytes(), 0.5, 10**12))
    t0 = time.monotonic()
    r = _run("vehicle", "fit", sandbox / "jump.ulg", "--out", sandbox / "fit", "--mass", "2.0", tmpdir=sandbox / "tmp")
    assert r.returncode == 0 and time.monotonic() - t0 < 120, r.stderr
    assert any("longest continuous stretch" in n for n in json.loads((sandbox / "fit" / "fit.json").read_text())["notes"])


def test_two_writers_of_one_new_file(sandbox: Path) -> None:  # class 6
    out = sandbox / "race.gpkg"
    a, b = (vinecli_proc("gis", "export", sandbox / "runs" / "m-s0", "--out", out) for _ in range(2))
    try:
        codes = sorted(p.wait(timeout=300) for p in (a, b))
        errs = [p.stderr.read() if p.stderr else "" for p in (a, b)]
    finally:
        kill_session(a)
        kill_session(b)
    assert codes == [0, 2], errs
    line = next(e for e in errs if "error" in e).strip().splitlines()
    assert len(line) == 1 and ("in use by pid" in line[0] or "exists" in line[0] or "meanwhile" in line[0])
    assert out.is_file() and _litter(sandbox) == []


def test_firmware_that_fails_or_speaks_garbage(sandbox: Path, flat_world_dir: Path) -> None:  # classes 3, 4
    tmpdir = sandbox / "tmp"
    (sandbox / "fw.yaml").write_text(yaml.safe_dump({**TAKEOFF, "max_duration_s": 60.0}))
    px4 = _script(sandbox / "px4" / "bin" / "px4", "#!/bin/sh\necho 'no airframe'\nexit 3\n")
    (sandbox / "px4" / "etc" / "init.d-posix").mkdir(parents=True)
    (sandbox / "px4" / "etc" / "init.d-posix" / "rcS").write_text("")
    r = _run("run", "mission", sandbox / "fw.yaml", "--world", flat_world_dir, "--out", sandbox / "fwruns",
             "--autopilot", "px4", "--px4-bin", px4, tmpdir=tmpdir)
    assert r.returncode == 3 and "firmware/px4.log" in r.stderr
    summary = json.loads((sandbox / "fwruns" / "fw-s0" / "summary.json").read_text())
    assert all((sandbox / "fwruns" / "fw-s0" / f).is_file() for f in summary["firmware"]["files"])
    garbage = _script(sandbox / "garbage" / "arducopter", f"#!{sys.executable}\n" + (
        "import socket, sys, time\ni = int(sys.argv[sys.argv.index('-I') + 1])\n"
        "s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)\n"
        "while True:\n    s.sendto(bytes(range(200)), ('127.0.0.1', 9002 + 10 * i)); time.sleep(0.001)\n"))
    t0 = time.monotonic()
    r = _run("run", "mission", sandbox / "fw.yaml", "--world", flat_world_dir, "--out", sandbox / "fwruns2",
             "--autopilot", "ardupilot", "--ardupilot-bin", garbage, tmpdir=tmpdir)
    assert r.returncode == 3 and "not servo frames" in r.stderr and time.monotonic() - t0 < 120, r.stderr
    assert _litter(sandbox) == []


def test_sigterm_twice_and_a_wrapper_killed_with_9(sandbox: Path, flat_world_dir: Path) -> None:  # classes 5, 7
    m = mission(sandbox, "idle", text=IDLE)
    runs = sandbox / "sigruns"
    proc = vinecli_proc("run", "mission", m, "--world", flat_world_dir, "--out", runs)
    try:
        assert wait_for(lambda: (runs / ".idle-s0.lock").exists() or proc.poll() is not None, 180)
        time.sleep(1.0)
        proc.send_signal(signal.SIGTERM)
        time.sleep(0.3)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        kill_session(proc)
    assert proc.returncode in (143, -signal.SIGTERM) and "SIGTERM" in err, err
    wrapper = _script(sandbox / "wrapped" / "arducopter", "#!/bin/sh\nexport X=1\n"
                      f"{sys.executable} -c 'import time; time.sleep(600)' arducopter-stand-in \"$@\"\n")
    (sandbox / "fw2.yaml").write_text(yaml.safe_dump({**TAKEOFF, "name": "fw2"}))
    proc = vinecli_proc("run", "mission", sandbox / "fw2.yaml", "--world", flat_world_dir, "--out", sandbox / "wr",
                        "--autopilot", "ardupilot", "--ardupilot-bin", wrapper)
    tree: set[int] = set()
    try:
        assert wait_for(lambda: any("arducopter-stand-in" in _cmdline(p) for p in descendants(proc.pid)), 120)
        tree = descendants(proc.pid)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        assert wait_for(lambda: not any(alive(p) for p in tree), 5.0, every=0.05), [_cmdline(p) for p in tree]
    finally:
        kill_session(proc)
        for p in tree:
            with __import__("contextlib").suppress(ProcessLookupError):
                os.kill(p, signal.SIGKILL)
    r = _run("--version", tmpdir=sandbox / "tmp")  # the next start sweeps what kill -9 left
    assert r.returncode == 0 and not [p for p in (sandbox / "tmp").iterdir() if "." in p.name]
    assert _litter(runs) == []


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def test_a_young_crop_is_planned(sandbox: Path) -> None:  # class 12
    import rasterio
    from rasterio.transform import from_origin

    z, x, y = YoungCrop(seed=6).heights()
    tif = sandbox / "young.tif"
    with rasterio.open(tif, "w", driver="GTiff", width=x.size, height=y.size, count=1, dtype="float32",
                       crs="EPSG:32616", transform=from_origin(296600.0, 4888200.0, 0.01, 0.01)) as ds:
        ds.write(z[::-1].astype("float32"), 1)
    r = cli("plan", "rows", tif, "--out", sandbox / "young.plan")
    assert r.exit_code == 0 and "rows: 7 rows" in r.stdout, r.output
    bare = np.asarray(YoungCrop(seed=6, tall_m=0.0).heights()[0])
    with rasterio.open(sandbox / "bare.tif", "w", driver="GTiff", width=x.size, height=y.size, count=1,
                       dtype="float32", crs="EPSG:32616", transform=from_origin(296600.0, 4888200.0, 0.01, 0.01)) as ds:
        ds.write(bare[::-1].astype("float32"), 1)
    r = cli("plan", "rows", sandbox / "bare.tif", "--out", sandbox / "bare.plan", "--spacing", "0.77")
    assert r.exit_code == 2 and "no rows at the given pattern" in error_line(r)
    shutil.rmtree(sandbox / "tmp", ignore_errors=True)
