"""Which tests run together on one pytest-xdist worker (``make test`` runs the suite on every core; the scheduler in
tests/conftest.py asks :func:`scope_of` for each collected test's node id).

* The real-firmware tests (real PX4 / ArduPilot SITL, some of them beside a CPU hog) share the scope
  :data:`FIRMWARE`: one worker runs them one after the other. A test is one when it, or its module's
  ``pytestmark``, carries the ``px4`` or ``ardupilot`` marker, or when it takes one of :data:`FIRMWARE_FIXTURES`.
* Every other test runs with the rest of its module (the module-scoped fixtures are made once).

Decided from the test modules' source (the xdist controller has node ids, not collected items): each module is
parsed once.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

__all__ = ["FIRMWARE", "FIRMWARE_FIXTURES", "scope_of"]

FIRMWARE = "real firmware"
#: fixtures that start a real firmware (tests/sitl/px4/real_px4.py, tests/sitl/ardupilot/real_ardupilot.py)
FIRMWARE_FIXTURES = frozenset({"px4_bin", "real_px4", "ardupilot_bin"})
_MARKS = ("mark.px4", "mark.ardupilot")


@functools.cache
def _firmware_tests(module: Path) -> tuple[bool, frozenset[str]]:
    """(every test of ``module`` is a firmware test, the names of its firmware test functions)."""
    try:
        source = module.read_text()
        tree = ast.parse(source)
    except (OSError, SyntaxError, ValueError):
        return False, frozenset()
    whole = any(isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "pytestmark" for t in node.targets)
                and any(m in (ast.get_source_segment(source, node.value) or "") for m in _MARKS) for node in tree.body)
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and node.name.startswith("test"):
            decorators = " ".join(ast.get_source_segment(source, d) or "" for d in node.decorator_list)
            args = {a.arg for a in node.args.args}
            if any(m in decorators for m in _MARKS) or args & FIRMWARE_FIXTURES:
                names.add(node.name)
    return whole, frozenset(names)


def scope_of(root: Path, nodeid: str) -> str:
    """The scope of the test ``nodeid`` (rootdir-relative): :data:`FIRMWARE`, or its module's path."""
    module = nodeid.split("::", 1)[0]
    function = nodeid.split("::")[-1].split("[", 1)[0]
    whole, names = _firmware_tests(root / module)
    return FIRMWARE if whole or function in names else module
