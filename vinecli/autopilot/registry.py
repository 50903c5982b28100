"""Autopilot backends by name.

Backends register in the ``vinecli.autopilots`` entry-point group (``pyproject.toml``), so a
plugin package can add one without touching vinecli. The built-in names also resolve
without installed metadata (an editable checkout before reinstalling).
"""

from __future__ import annotations

import functools
import importlib
import logging
from importlib.metadata import entry_points
from typing import Any

from vinecli.autopilot.base import Autopilot
from vinecli.errors import AutopilotError, InputError

log = logging.getLogger(__name__)

GROUP = "vinecli.autopilots"

#: built-in backends, "module:attribute"
BUILTIN: dict[str, str] = {
    "builtin": "vinecli.autopilot.builtin:BuiltinAutopilot",
    "px4": "vinecli.sitl.px4.backend:Px4SitlAutopilot",
    "ardupilot": "vinecli.sitl.ardupilot.backend:ArdupilotSitlAutopilot",
}


@functools.cache
def _targets() -> dict[str, str]:
    """Every backend's target (read-only); the installed packages' entry points are scanned once per process
    (~130 packages' metadata: a batch worker would scan them for every case)."""
    found = dict(BUILTIN)
    for ep in entry_points(group=GROUP):
        found[ep.name] = ep.value
    return found


def available_autopilots() -> list[str]:
    """Names of every known backend (entry points + built-ins), sorted."""
    return sorted(_targets())


def _load(target: str) -> Any:
    module, _, attr = target.partition(":")
    obj: Any = importlib.import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


def make_autopilot(name: str, **opts: Any) -> Autopilot:
    """A new backend instance by name (``builtin``, ``px4`` or a plugin); unknown -> InputError."""
    targets = _targets()
    target = targets.get(name)
    if target is None:
        raise InputError(f"unknown autopilot {name!r} (available: {', '.join(sorted(targets))})")
    try:
        cls = _load(target)
    except (ImportError, AttributeError) as exc:
        raise AutopilotError(f"autopilot {name!r}: cannot load {target}: {exc}") from exc
    return cls(**opts)
