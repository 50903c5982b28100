"""vinecli: simulation pipeline for precision-agriculture spraying drones.

DSM / point cloud -> terrain -> world -> missions (PyBullet, built-in autopilot or PX4 SITL) -> report.
"""

__version__ = "0.1.0"

import os as _os  # noqa: E402

# numpy's OpenBLAS starts a thread per core at its first matrix call, and those threads spin for a
# while after each call: vinecli only solves small systems (estimator gains, mixer), and in a batch
# the spinning threads take the core of the other worker (BENCHMARKS.md, "Batch throughput")
_os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from vinecli import native as _native  # noqa: E402 - compiled kernel or its sources (vinecli/native.py)

_native.install()
