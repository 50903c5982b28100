"""Failsafes of a run: from the autopilot's ``failsafe`` events to summary.json and back to text.

summary.json ``failsafes``: ``[{t_s, cause, action, detail, position_enu}]`` in time order;
``cause`` is ``geofence``, ``lost_control``, ``low_battery`` or, from the PX4 backend, PX4's warning text;
``action`` what the autopilot did (``hold``, ``rtl``, ``land``, ``terminate``, ``warn``,
``disarm``); ``position_enu`` the true vehicle position (m, world ENU) at that step. Every
failsafe switches the sprayer off for the rest of the flight (until the vehicle is armed again).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from vinecli.types import Event

#: how a cause reads in reports
CAUSE_WORDS = {"geofence": "geofence breach", "lost_control": "lost control", "low_battery": "low battery"}


def failsafes_from_events(events: Iterable[Event]) -> list[dict[str, Any]]:
    """The ``failsafe`` events as summary.json entries (t_s in s, position_enu in m)."""
    out: list[dict[str, Any]] = []
    for ev in events:
        if ev.kind != "failsafe":
            continue
        d = ev.data
        pos = d.get("position_enu") or d.get("position_est_enu") or [None, None, None]
        out.append({"t_s": round(ev.t_us * 1e-6, 4), "cause": str(d.get("cause", "unknown")),
                    "action": str(d.get("action", "")), "detail": str(d.get("detail", "")),
                    "position_enu": [None if v is None else round(float(v), 3) for v in pos]})
    out.sort(key=lambda f: f["t_s"])
    return out


def describe_failsafe(fs: Mapping[str, Any]) -> str:
    """One line, e.g. ``geofence breach at 10.06 s → hold; sprayer off``."""
    cause = str(fs.get("cause", "failsafe"))
    words = CAUSE_WORDS.get(cause, cause.replace("_", " "))
    try:
        t = f" at {float(fs.get('t_s')):.2f} s"  # type: ignore[arg-type]
    except (TypeError, ValueError):
        t = ""
    action = str(fs.get("action") or "")
    return f"{words}{t} → {action}; sprayer off" if action else f"{words}{t}; sprayer off"


def describe_failsafes(failsafes: Sequence[Mapping[str, Any]] | None) -> str:
    """All failsafes of a run joined with '; ' ('' when none)."""
    return "; ".join(describe_failsafe(f) for f in failsafes or [] if isinstance(f, Mapping))
