"""Silence what PyBullet's C code prints (``pybullet build time``, ``argv[0]=``).

PyBullet writes those lines with C ``printf`` straight to file descriptors 1 and 2, past
Python's ``sys.stdout``, so they would land in the middle of the CLI's tables and in the
output of ``--json`` commands. :func:`c_output_silenced` points both descriptors at
``/dev/null`` for the duration of the block.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def c_output_silenced() -> Iterator[None]:
    """Redirect file descriptors 1 and 2 to /dev/null inside the block (Python streams flushed)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)
