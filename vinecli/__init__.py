"""vinecli: simulation pipeline for precision-agriculture spraying drones.

DSM / point cloud -> terrain -> world -> missions (PyBullet, built-in autopilot or PX4 SITL) -> report.

The packages, their floors and where each feature lives: docs/architecture.md. This module may import only the
compiled kernel's switch (:mod:`vinecli.native`), so ``import vinecli`` stays light.
"""

__version__ = "0.1.0"

import os as _os  # noqa: E402

# numpy's OpenBLAS starts a thread per core at its first matrix call, and those threads spin for a
# while after each call: vinecli only solves small systems (estimator gains, mixer), and in a batch
# the spinning threads take the core of the other worker (BENCHMARKS.md, "Batch throughput")
_os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _pin_cpu_dispatch() -> None:
    """The same floating-point results on every x86-64 machine with AVX2 and FMA (any of the last decade).

    numpy's OpenBLAS picks its kernels by the CPU when it loads (DYNAMIC_ARCH): the AVX-512 (SkylakeX) kernels add in
    another order than the AVX2 (Haswell, Zen) ones, so the small least-squares fits of a run (the world's fast
    geodetic map, the mixer's pseudo-inverse) differ in the last bit and a run's trajectory with them; numpy's own
    loops dispatch likewise (AVX-512 transcendental functions). Both are pinned to the AVX2 level before numpy
    loads, so golden runs and seeds give the same bytes on an AVX-512 machine as on an AVX2 one. Too late once
    numpy is imported (a script importing numpy before vinecli gets the machine's own kernels); an explicit
    OPENBLAS_CORETYPE / NPY_DISABLE_CPU_FEATURES in the environment wins.
    """
    import platform
    import sys

    if "numpy" in sys.modules or platform.machine() not in ("x86_64", "AMD64"):
        return
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            flags = next((line.split(":", 1)[1].split() for line in f if line.startswith("flags")), [])
    except OSError:
        return
    if {"avx2", "fma"} <= set(flags):
        _os.environ.setdefault("OPENBLAS_CORETYPE", "Haswell")
        _os.environ.setdefault("NPY_DISABLE_CPU_FEATURES", "X86_V4 AVX512_ICL AVX512_SPR")


_pin_cpu_dispatch()

from vinecli import native as _native  # noqa: E402 - compiled kernel or its sources (vinecli/native.py)

_native.install()
