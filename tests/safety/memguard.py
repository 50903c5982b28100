"""Run Python code or vinecli in a child process under an address-space ceiling and read its peak RSS.

The ceiling (``RLIMIT_AS``) keeps a test of an unbounded allocation (an 8.2 GB deposition grid for a
400 m spray height, without the cell budget) from taking the shared machine down: the child gets MemoryError
instead. The peak resident set comes from ``wait4``'s ``ru_maxrss`` of that one child.
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


def _limit() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (AS_CEILING, AS_CEILING))


def run_child(args: list[str], cwd: Path | None = None, timeout: float = 600.0) -> ChildRun:
    """Run ``args`` under the ceiling; its exit code, peak RSS (MB, ``wait4`` of that child) and output."""
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
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
        return ChildRun(proc.returncode, usage.ru_maxrss / 1024.0, out.read(), err.read())


def run_python(code: str, cwd: Path | None = None, timeout: float = 600.0) -> ChildRun:
    """Run ``code`` with this interpreter under the ceiling."""
    return run_child([sys.executable, "-c", code], cwd=cwd, timeout=timeout)
