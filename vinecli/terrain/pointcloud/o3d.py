"""Lazy Open3D import with its console chatter turned down (library code never prints)."""

from __future__ import annotations

from functools import cache
from types import ModuleType

from vinecli.errors import RuntimeFailure


@cache
def o3d() -> ModuleType:
    """Import ``open3d`` once, set its verbosity to errors only, and return the module."""
    try:
        import open3d
    except ImportError as exc:  # pragma: no cover - depends on the installed extras
        raise RuntimeFailure("open3d is not installed: pip install 'vinecli[mesh]'") from exc
    open3d.utility.set_verbosity_level(open3d.utility.VerbosityLevel.Error)
    return open3d
