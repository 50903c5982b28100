"""Run Python code or vinecli in a child process under an address-space ceiling and read its peak RSS.

The ceiling (``RLIMIT_AS``) keeps a test of an unbounded allocation (an 8.2 GB deposition grid for a
400 m spray height, without the cell budget) from taking the shared machine down: the child gets MemoryError
instead. The peak resident set is the child's own ``VmHWM`` (``/proc/self/status``), which it writes at exit
(a ``sitecustomize`` this module puts on its ``PYTHONPATH``): ``wait4``'s ``ru_maxrss`` also counts the
parent's resident set at the fork (a pytest-xdist worker that ran many tests holds 800+ MB), so it is only the
fallback for a child that died without writing.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

#: the child may map at most this much (guard only; the RSS limit under test is far below)
AS_CEILING = 6 << 30


@dataclass
class ChildRun:
    returncode: int
    peak_rss_mb: float
    stdout: str
    stderr: str


#: written as sitecustomize.py beside the child: at exit, the process writes its own peak resident set (kB)
SITECUSTOMIZE = """\
import atexit, os


def _write_vmhwm():
    with open("/proc/self/status") as f:
        kb = next((line.split()[1] for line in f if line.startswith("VmHWM:")), None)
    if kb is not None:
        with open(os.path.join(os.environ["MEMGUARD_DIR"], str(os.getpid())), "w") as out:
            out.write(kb)


if os.environ.get("MEMGUARD_DIR"):
    atexit.register(_write_vmhwm)
"""


def _limit() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (AS_CEILING, AS_CEILING))


def run_child(args: list[str], cwd: Path | None = None, timeout: float = 600.0) -> ChildRun:
    """Run ``args`` (a Python program) under the ceiling; its exit code, peak RSS (MB, its own ``VmHWM``; see
    the module doc) and output."""
    with tempfile.TemporaryDirectory(prefix="memguard-") as tmp:
        site = Path(tmp) / "site"
        site.mkdir()
        (site / "sitecustomize.py").write_text(SITECUSTOMIZE)
        path = os.pathsep.join(p for p in (str(site), os.environ.get("PYTHONPATH", "")) if p)
        res = _run(args, cwd, timeout, {**os.environ, "PYTHONPATH": path, "MEMGUARD_DIR": tmp})
        own = Path(tmp) / str(res.pid)
        if own.is_file():
            res.child.peak_rss_mb = int(own.read_text()) / 1024.0
        return res.child


@dataclass
class _Ran:
    pid: int
    child: ChildRun


def _run(args: list[str], cwd: Path | None, timeout: float, env: dict[str, str]) -> _Ran:
    env = {**env, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(args, cwd=cwd, stdout=out, stderr=err, text=True, preexec_fn=_limit, env=env)
        deadline = time.monotonic() + timeout
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() > deadline:
                proc.kill()
            time.sleep(0.05)
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        return _Ran(proc.pid, ChildRun(proc.returncode, usage.ru_maxrss / 1024.0, out.read(), err.read()))


def run_python(code: str, cwd: Path | None = None, timeout: float = 600.0) -> ChildRun:
    """Run ``code`` with this interpreter under the ceiling."""
    return run_child([sys.executable, "-c", code], cwd=cwd, timeout=timeout)
