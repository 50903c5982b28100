"""A CPU hog for load tests: ``with cpu_hog(2.0):`` runs 2 x CPU-count busy processes for the block."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager

_BUSY = "while True:\n    sum(i * i for i in range(10000))\n"


@contextmanager
def cpu_hog(per_cpu: float = 2.0) -> Iterator[int]:
    """Busy processes (``per_cpu`` per CPU) for the duration of the block; yields how many."""
    n = max(1, round(per_cpu * (os.cpu_count() or 1)))
    procs = [subprocess.Popen([sys.executable, "-c", _BUSY]) for _ in range(n)]
    try:
        yield n
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()
