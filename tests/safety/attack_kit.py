"""What the issue-20 tests share: fingerprints of every input, the CLI in-process and as a real process,
process trees, small missions and worlds."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time
from contextlib import suppress
from pathlib import Path

from repo_paths import REPO
from typer.testing import CliRunner

from vinecli.cli.app import app

runner = CliRunner()
SAMPLE_DSM = REPO / "worlds" / "sample" / "fieldimager_potato_plots_dsm_3cm_utm16n.tif"
PLAN = REPO / "tests" / "data" / "vineyard_spray.plan"

MISSION = """\
name: {name}
vehicle: x500-sprayer
tank_fill_l: 0.5
max_duration_s: {maxdur}
record_rate_hz: {rate}
phases:
  - {{type: takeoff, altitude_agl_m: 1.5}}
  - {{type: land}}
"""

#: idles on the ground for hours: whatever the machine's speed, the test's signal comes first
IDLE = """\
name: {name}
vehicle: x500-sprayer
max_duration_s: 36000
record_rate_hz: 1
phases:
  - {{type: open_loop, duration_s: 36000, rotor_speeds_rad_s: 0}}
"""

#: a flat world with two rows (plan rows needs rows; building it takes a second), where tests/data's
#: vineyard_spray.plan flies
ROWS_WORLD = """\
name: rowsworld
terrain: {type: flat, z_m: 0.0, size_m: 100.0}
origin: {lat: 44.7, lon: 8.03, alt: 250.0}
vehicle: x500-sprayer
rows: [[[-10.0, -3.0], [10.0, -3.0]], [[-10.0, 3.0], [10.0, 3.0]]]
"""


def mission(d: Path, name: str = "quick", *, maxdur: float = 20.0, rate: float = 10.0, text: str = MISSION) -> Path:
    p = d / f"{name}.yaml"
    p.write_text(text.format(name=name, maxdur=maxdur, rate=rate))
    return p


def fingerprint(*roots: Path) -> dict[str, str]:
    """sha256 of every file under ``roots`` (a file root is itself), and every folder and link by name."""
    out: dict[str, str] = {}
    for root in roots:
        items = [root] if not root.is_dir() or root.is_symlink() else [root, *sorted(root.rglob("*"))]
        for p in items:
            if p.is_symlink():
                out[str(p)] = "link:" + os.readlink(p)
            elif p.is_file():
                out[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
            elif p.is_dir():
                out[str(p)] = "dir"
    return out


def cli(*args: object):  # noqa: ANN201 - click's Result
    """``vinecli ARGS`` in this process."""
    return runner.invoke(app, [str(a) for a in args])


def error_line(r) -> str:  # noqa: ANN001
    """The one error line a refused command printed (asserts there is exactly one)."""
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("vinecli: error:"), lines[0]
    return " ".join(lines[0].split())


def vinecli_proc(*args: object, cwd: Path | None = None) -> subprocess.Popen[str]:
    """``vinecli ARGS`` as a real process in its own session (so a test can clean up its whole tree)."""
    src = str(REPO)
    env = {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", ""), "COLUMNS": "200"}
    return subprocess.Popen([sys.executable, "-m", "vinecli", *map(str, args)], cwd=cwd, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)


def kill_session(proc: subprocess.Popen[str]) -> None:
    with suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)


def wait_for(predicate, timeout: float = 120.0, every: float = 0.1) -> bool:  # noqa: ANN001
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(every)
    return False
