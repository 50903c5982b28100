"""Which tests run together on one pytest-xdist worker (``make test`` runs the suite on every core; the scheduler in
tests/conftest.py asks :func:`scope_of` for each collected test's node id).

* The real-firmware tests (real PX4 / ArduPilot SITL, some of them beside a CPU hog) share one scope per
  firmware, :data:`PX4` and :data:`ARDUPILOT`: one worker runs a firmware's tests one after the other, and the
  two firmwares' chains may run at the same time on two workers (each firmware process takes a free instance
  and its ports under a lock file: vinecli.sitl.process.reserve_firmware_instance). A test is one when it, or
  its module's ``pytestmark``, carries the ``px4`` or ``ardupilot`` marker, or when it takes one of
  :data:`FIRMWARE_FIXTURES`; a test of both firmwares goes with ArduPilot's.
* Every other test runs with the rest of its module (the module-scoped fixtures are made once).

Decided from the test modules' source (the xdist controller has node ids, not collected items): each module is
parsed once. :func:`scope_seconds` says how long each scope took in a measured run (tests/scope_seconds.json,
written by benchmarks/suite_durations.py): the scheduler starts the longest first, so that no long scope starts
last and sets the wall time alone.
"""

from __future__ import annotations

import ast
import functools
import json
from pathlib import Path

__all__ = ["ARDUPILOT", "FIRMWARE_FIXTURES", "PX4", "scope_of", "scope_seconds"]

PX4 = "real firmware: PX4"
ARDUPILOT = "real firmware: ArduPilot"
#: fixtures that start a real firmware (tests/sitl/px4/real_px4.py, tests/sitl/ardupilot/real_ardupilot.py)
FIRMWARE_FIXTURES = {"px4_bin": PX4, "real_px4": PX4, "ardupilot_bin": ARDUPILOT}
_MARKS = {"mark.px4": PX4, "mark.ardupilot": ARDUPILOT}
#: seconds per scope in a measured run (benchmarks/suite_durations.py writes it)
SCOPE_SECONDS = Path(__file__).with_name("scope_seconds.json")


def _firmware_in(text: str, names: set[str] | None = None) -> str | None:
    """The firmware scope of a test whose decorators (or module ``pytestmark``) are ``text`` and whose arguments
    are ``names``; None for no firmware. ArduPilot's when it needs both."""
    found = {scope for mark, scope in _MARKS.items() if mark in text}
    found |= {FIRMWARE_FIXTURES[n] for n in (names or set()) & FIRMWARE_FIXTURES.keys()}
    return ARDUPILOT if ARDUPILOT in found else PX4 if found else None


@functools.cache
def _firmware_tests(module: Path) -> tuple[str | None, dict[str, str]]:
    """(the firmware scope of every test of ``module``, or None; the firmware scope of each firmware test function)."""
    try:
        source = module.read_text()
        tree = ast.parse(source)
    except (OSError, SyntaxError, ValueError):
        return None, {}
    whole = None
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "pytestmark" for t in node.targets):
            whole = whole or _firmware_in(ast.get_source_segment(source, node.value) or "")
    names = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and node.name.startswith("test"):
            decorators = " ".join(ast.get_source_segment(source, d) or "" for d in node.decorator_list)
            scope = _firmware_in(decorators, {a.arg for a in node.args.args})
            if scope is not None:
                names[node.name] = scope
    return whole, names


def scope_of(root: Path, nodeid: str) -> str:
    """The scope of the test ``nodeid`` (rootdir-relative): :data:`PX4`, :data:`ARDUPILOT`, or its module's path."""
    module = nodeid.split("::", 1)[0]
    function = nodeid.split("::")[-1].split("[", 1)[0]
    whole, names = _firmware_tests(root / module)
    return names.get(function) or whole or module


def scope_seconds() -> dict[str, float]:
    """Seconds each scope took in the measured run of :data:`SCOPE_SECONDS` (empty without the file)."""
    try:
        return {str(k): float(v) for k, v in json.loads(SCOPE_SECONDS.read_text()).items()}
    except (OSError, ValueError, AttributeError):
        return {}
