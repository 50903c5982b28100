"""Where a real-firmware run's wall time goes: a phase timer for the firmware backends, and its breakdown.

:func:`install` (called by the ``sitecustomize`` that ``benchmarks/firmware_chains.py --phases`` puts on
``PYTHONPATH``, so that batch workers and ``vinecli`` subprocesses have it too) wraps
``Px4SitlAutopilot`` / ``ArdupilotSitlAutopilot`` as their modules load and appends one JSON line per phase
to ``$FWPHASE_LOG``: start (reset), PX4's first HIL_ACTUATOR_CONTROLS or ArduPilot ready to arm (booted),
armed, the run's end, close; a pytest plugin (``-p firmware_phases``) adds each test's start and end.
:func:`breakdown` prints, per test, its wall time, the time before its first firmware started (fixtures,
world builds) and per firmware run start->ready, ->armed, the flight and the close.

    python benchmarks/firmware_phases.py PHASES.jsonl
"""

from __future__ import annotations

import functools
import importlib.abc
import json
import os
import sys
import threading
import time
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

_lock = threading.Lock()


def record(ev: str, **data: Any) -> None:
    """One phase line (wall time, pid, event) into ``$FWPHASE_LOG``."""
    path = os.environ.get("FWPHASE_LOG")
    if path:
        line = json.dumps({"t": time.time(), "pid": os.getpid(), "ev": ev, **data}, default=str)
        with _lock, open(path, "a") as f:
            f.write(line + "\n")


def _wrap(cls: Any, name: str, before: Any = None, after: Any = None) -> None:
    orig = getattr(cls, name)

    @functools.wraps(orig)
    def wrapped(self: Any, *a: Any, **k: Any) -> Any:
        if before:
            before(self)
        try:
            return orig(self, *a, **k)
        finally:
            if after:
                after(self)
    setattr(cls, name, wrapped)


def _watch_step(cls: Any, fw: str, armed: Any) -> None:
    """Record the first armed step and the step the run's status changes."""
    def before(s: Any) -> None:
        s._fwp = (armed(s), s._status.status)

    def after(s: Any) -> None:
        was_armed, status = s._fwp
        if armed(s) and not was_armed:
            record(f"{fw}_armed")
        if s._status.status != status:
            record(f"{fw}_end", status=str(s._status.status.value))
    _wrap(cls, "step", before, after)


def _px4(mod: Any) -> None:
    c = mod.Px4SitlAutopilot
    _wrap(c, "reset", before=lambda s: record("px4_start"))
    _wrap(c, "_boot_step", before=lambda s: setattr(s, "_fwp_ls", s.lockstep),
          after=lambda s: s.lockstep and not s._fwp_ls and record("px4_ready"))
    _watch_step(c, "px4", lambda s: getattr(s, "armed", False))
    _wrap(c, "close", before=lambda s: s._closed or record("px4_close"), after=lambda s: record("px4_closed"))


def _ardupilot(mod: Any) -> None:
    c = mod.ArdupilotSitlAutopilot
    _wrap(c, "reset", before=lambda s: record("ap_start"))
    _wrap(c, "_boot", after=lambda s: s._booted and record("ap_ready", boot_s=s.boot_s))
    _watch_step(c, "ap", lambda s: bool(s.client and s.client.state.armed))
    _wrap(c, "close", before=lambda s: s._closed or record("ap_close"), after=lambda s: record("ap_closed"))


_PATCHES = {"vinecli.sitl.px4.backend": _px4, "vinecli.sitl.ardupilot.backend": _ardupilot}


class _Finder(importlib.abc.MetaPathFinder):
    """Patches a backend module right after it executed, before anything imports names from it."""

    def find_spec(self, name: str, path: Any, target: Any = None) -> Any:
        if name not in _PATCHES:
            return None
        for finder in sys.meta_path:
            spec = None if finder is self else getattr(finder, "find_spec", lambda *a: None)(name, path, target)
            if spec is not None:
                break
        else:
            return None
        loader = spec.loader
        run = loader.exec_module

        def exec_module(module: Any) -> None:
            run(module)
            _PATCHES[name](module)
        loader.exec_module = exec_module
        return spec


def install() -> None:
    """Put the phase timer in place (only with ``$FWPHASE_LOG`` set)."""
    if os.environ.get("FWPHASE_LOG"):
        sys.meta_path.insert(0, _Finder())


def pytest_runtest_protocol(item: Any, nextitem: Any) -> None:
    record("test", node=item.nodeid)


def pytest_runtest_logfinish(nodeid: str, location: Any) -> None:
    record("test_end", node=nodeid)


def breakdown(path: Path) -> dict[str, float]:
    """Print the per-test breakdown of a phase log; the chain's totals (s) per firmware and phase."""
    tests: list[dict[str, Any]] = []
    for e in (json.loads(x) for x in path.read_text().splitlines()):
        if e["ev"] == "test":
            tests.append({"node": e["node"], "t0": e["t"], "t1": e["t"], "ev": []})
        elif e["ev"] == "test_end" and tests:
            tests[-1]["t1"] = e["t"]
        elif tests:
            tests[-1]["ev"].append(e)
    total: Counter[str] = Counter()
    for t in tests:
        runs: dict[tuple[int, int], dict[str, float]] = defaultdict(dict)
        current: dict[int, tuple[int, int]] = {}
        for e in t["ev"]:
            fw, _, what = e["ev"].partition("_")
            if what == "start":
                current[e["pid"]] = (e["pid"], len(runs))
            if e["pid"] in current:
                runs[current[e["pid"]]].setdefault(what, e["t"])
                runs[current[e["pid"]]]["fw"] = 0.0 if fw == "px4" else 1.0
        firsts = [r["start"] for r in runs.values() if "start" in r]
        wall = t["t1"] - t["t0"]
        print(f"{wall:7.1f} s  {t['node'].split('::')[-1][:80]}  (before its first firmware "
              f"{(min(firsts) if firsts else t['t1']) - t['t0']:.1f} s)")
        for r in runs.values():
            fw = "px4" if r["fw"] == 0.0 else "ardupilot"
            parts = {"ready": ("start", "ready"), "arming": ("ready", "armed"), "flight": ("armed", "end"),
                     "close": ("close", "closed")}
            got = {k: r[b] - r[a] for k, (a, b) in parts.items() if a in r and b in r}
            print(f"      {fw:9s} " + "  ".join(f"{k} {got[k]:6.2f}" if k in got else f"{k}    -  " for k in parts))
            for k, v in got.items():
                total[f"{fw} {k}"] += v
        total["tests"] += wall
    return dict(total)


if __name__ == "__main__":
    for p in sys.argv[1:]:
        print(f"## {p}")
        print({k: round(v, 1) for k, v in breakdown(Path(p)).items()})
