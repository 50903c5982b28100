"""The compiled kernel: which modules mypyc compiles, and when the compiled copies are used.

The per-step modules (the loop, physics models, sensors, estimator, controllers, phases) are plain
typed Python and stay the reference. ``make native`` (``scripts/build_native.py``) compiles them
ahead of time with mypyc into extension modules beside the sources and records a digest of every
source in ``vinecli/native.json``. Python imports an extension before a ``.py`` of the same name,
so the compiled copies are used when they exist, unless:

* ``VINECLI_PURE_PYTHON=1`` is set (the reference path, e.g. to compare against it), or
* any compiled source changed since the build (a stale kernel): then every module of the kernel
  is imported from its source, with one warning, since compiled modules call each other directly
  and a mix would run old code.

:func:`install` (run by ``vinecli/__init__.py``) puts a finder first on ``sys.meta_path`` that
serves the sources in those cases. Same floating-point operations in the same order: the compiled
and the pure-Python runs are bit-identical (``tests/sim/test_native.py``).
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
import os
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType

PACKAGE_DIR = Path(__file__).resolve().parent
MANIFEST = PACKAGE_DIR / "native.json"
PURE_ENV = "VINECLI_PURE_PYTHON"
#: extra C compiler flags of the kernel: IEEE double operations one by one, as CPython evaluates them (no
#: contraction of a * b + c into a fused multiply-add), so compiled and pure runs agree bit for bit by construction
CFLAGS: tuple[str, ...] = ("-ffp-contract=off",)

#: modules run every physics step (paths relative to the package), compiled by mypyc
KERNEL: tuple[str, ...] = (
    "sim/runner.py",
    "sim/loop.py",
    "sim/vehicle_physics.py",
    "sim/ground_events.py",
    "sim/spray_groups.py",
    "sim/recorder.py",
    "sim/row.py",
    "sim/perfect_estimator.py",
    "flight/motor.py",
    "flight/aero.py",
    "flight/sensors.py",
    "flight/tank.py",
    "flight/battery.py",
    "flight/wind.py",
    "flight/dryden.py",
    "flight/rangefinder.py",
    "autopilot/estimate.py",
    "autopilot/estimator.py",
    "autopilot/land_detector.py",
    "autopilot/hover_thrust.py",
    "autopilot/terrain.py",
    "autopilot/builtin.py",
    "autopilot/supervisor.py",
    "autopilot/phases/phase.py",
    "autopilot/phases/from_spec.py",
    "autopilot/phases/flight.py",
    "autopilot/phases/spray.py",
    "autopilot/geofence.py",
    "control/cascade.py",
    "control/pid.py",
    "control/allocation.py",
    "control/path.py",
    "frames.py",
    "types.py",
    "terrain/grid.py",
)


def module_name(rel: str) -> str:
    """``flight/motor.py`` -> ``vinecli.flight.motor``."""
    return "vinecli." + rel.removesuffix(".py").replace("/", ".")


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def source_digests(root: Path = PACKAGE_DIR) -> dict[str, dict[str, str | int]]:
    """Per kernel source under ``root`` (by relative path): its sha256 and, to skip hashing when
    nothing changed, its size and mtime (ns)."""
    out: dict[str, dict[str, str | int]] = {}
    for rel in KERNEL:
        st = (root / rel).stat()
        out[rel] = {"sha256": _digest(root / rel), "size": st.st_size, "mtime_ns": st.st_mtime_ns}
    return out


def stale_sources(manifest: Path = MANIFEST, root: Path = PACKAGE_DIR) -> list[str] | None:
    """Kernel sources changed since the build recorded in ``manifest``; None when there is no build.
    A source whose size and mtime match the record is taken as unchanged; any other is hashed."""
    try:
        built = json.loads(manifest.read_text())["sources"]
        stale = []
        for rel in KERNEL:
            rec = built[rel]
            st = (root / rel).stat()
            if (st.st_size, st.st_mtime_ns) != (rec["size"], rec["mtime_ns"]) and _digest(root / rel) != rec["sha256"]:
                stale.append(rel)
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return stale


def _runner_extension() -> Path:
    return PACKAGE_DIR / "sim" / ("runner" + importlib.machinery.EXTENSION_SUFFIXES[0])


def _usable(stale: list[str] | None) -> bool:
    """Built (the loop's extension is there) and no kernel source changed since (``stale`` = [])."""
    return stale == [] and _runner_extension().is_file()


def build_is_current() -> bool:
    """True when the compiled kernel is built and every kernel source is the one it was built from (what
    :func:`install` needs to use it, unless ``VINECLI_PURE_PYTHON=1`` asks for the sources)."""
    return _usable(stale_sources())


def is_compiled(module: ModuleType) -> bool:
    """True when ``module`` was loaded from a compiled extension."""
    return isinstance(getattr(module, "__loader__", None), importlib.machinery.ExtensionFileLoader)


class _SourcesFirst:
    """A ``sys.meta_path`` finder serving the ``.py`` source of the kernel modules, ahead of their
    compiled extensions (not an ``importlib.abc.MetaPathFinder``: that import costs ~15 ms)."""

    def __init__(self, names: set[str]) -> None:
        self.names = names

    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        if fullname not in self.names:
            return None
        leaf = fullname.rpartition(".")[2] + ".py"
        for entry in path or ():
            src = Path(entry) / leaf
            if src.is_file():
                return importlib.util.spec_from_file_location(fullname, src)
        return None


#: what :func:`install` decided for this process: ``compiled``, ``pure`` (asked for, or no build) or ``stale``
state = "pure"


def identity() -> dict[str, object]:
    """Which kernel this process runs and its build identity, as every run records it (summary.json ``kernel``):
    ``kind`` "compiled" or "pure" (``state`` says why: asked for, no build, or stale), ``sources_sha256`` (one
    digest of every kernel source this process runs: the same in both kernels of one checkout) and, compiled,
    the compiler, Python and C flags of the build and how it was built (``make native`` or ``wheel``)."""
    h = hashlib.sha256()
    for rel in KERNEL:
        h.update(f"{rel} {_digest(PACKAGE_DIR / rel)}\n".encode())
    doc: dict[str, object] = {"kind": "compiled" if state == "compiled" else "pure", "state": state,
                              "sources_sha256": h.hexdigest()}
    if state == "compiled":
        try:
            built = json.loads(MANIFEST.read_text())
        except (OSError, ValueError):
            built = {}
        doc.update({k: built.get(k) for k in ("compiler", "python", "cflags", "build")})
    return doc


def install() -> str:
    """Decide compiled or pure Python for this process (see the module doc); returns :data:`state`."""
    global state
    if os.environ.get(PURE_ENV, "") not in ("", "0"):
        state = "pure"
    else:
        stale = stale_sources()
        if _usable(stale):
            state = "compiled"
            return state
        state = "stale" if stale else "pure"  # else no build, a half-finished one, or its extensions gone
        if stale:
            warnings.warn(f"vinecli: the compiled kernel is older than {', '.join(stale)}: running pure Python "
                          "(rebuild it with `make native`)", RuntimeWarning, stacklevel=2)
    sys.meta_path.insert(0, _SourcesFirst({module_name(rel) for rel in KERNEL}))
    return state
