"""What PX4's own log (the kept ``.ulg``) says about PX4 itself after a run: did its periodic work run?

PX4 v1.15 SITL runs ``battery_simulator`` (``battery_status``, 5 Hz in the log) and ``load_mon``
(``cpuload``, 2 Hz) purely on periodic HRT timers. A race in PX4's own scheduler (see
:data:`vinecli.sitl.px4.process.SAFE_BOOT_PARAMS`) can drop those timers for good while everything driven
by sensor data keeps running: the topic then stops long before the log ends, and 5 s after
``battery_status`` stops PX4 warns "Preflight Fail: Battery unhealthy" (and fails safe) about a battery that
is fine. :func:`audit_ulog` finds such stops; :func:`apply_audit` puts them in the run as PX4's own fault
(``px4_scheduler_faults``, a ``px4_fault`` event with the evidence) and takes those warnings out of
``px4_battery_warnings``, which is about the pack.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vinecli.types import Event

log = logging.getLogger(__name__)

#: topics published only by a periodic HRT timer in PX4 v1.15 SITL, and the module that publishes each
PERIODIC_TOPICS = {"battery_status": "battery_simulator", "cpuload": "load_mon"}
#: a topic commander publishes at >= 2 Hz from boot to exit, whatever the timers do: the log's end
CLOCK_TOPIC = "vehicle_status"
#: a periodic topic whose last sample is this long before the log's end stopped (both run at >= 2 Hz)
STOP_GAP_S = 2.0
#: PX4 flags the battery unhealthy when its newest battery_status is older than this (batteryCheck.cpp)
BATTERY_STALE_S = 5.0


@dataclass
class TopicStop:
    """A periodic topic that stopped: its last sample and the log's end, s of PX4 time (= sim time)."""

    topic: str
    module: str
    last_s: float
    log_end_s: float


@dataclass
class LogAudit:
    """Findings in one ULog: stopped periodic topics and the battery warnings they explain."""

    stops: list[TopicStop] = field(default_factory=list)
    stale_battery_warnings: list[tuple[float, str]] = field(default_factory=list)  # (t s, text)

    def describe(self) -> str:
        """One line of evidence (PX4's fault, not the pack's)."""
        parts = [f"{s.topic} ({s.module}) last at {s.last_s:.2f} s" for s in self.stops]
        end = max(s.log_end_s for s in self.stops)
        text = (f"PX4's scheduler stopped running its periodic work: {', '.join(parts)}, while its log runs to "
                f"{end:.2f} s (a PX4 v1.15 HRT race, not the battery)")
        if self.stale_battery_warnings:
            text += "; " + "; ".join(f"'{w}' at {t:.2f} s is this stale battery_status" for t, w in self.stale_battery_warnings)
        return text


def audit_ulog(path: Path) -> LogAudit:
    """The stopped periodic topics of the ULog at ``path`` (empty audit for a log without them)."""
    from pyulog import ULog

    ulog = ULog(str(path), [*PERIODIC_TOPICS, CLOCK_TOPIC], True)  # a filtered parse: last_timestamp is theirs only
    audit = LogAudit()
    last: dict[str, float] = {}
    for d in ulog.data_list:
        ts = d.data["timestamp"]
        if len(ts):
            last[d.name] = max(last.get(d.name, 0.0), float(ts[-1]) * 1e-6)
    end_s = max(last.values(), default=0.0)
    for topic, module in PERIODIC_TOPICS.items():
        if topic in last and end_s - last[topic] > STOP_GAP_S:
            audit.stops.append(TopicStop(topic, module, last[topic], end_s))
    batt = last.get("battery_status")
    if batt is not None and any(s.topic == "battery_status" for s in audit.stops):
        for m in ulog.logged_messages:
            t = m.timestamp * 1e-6
            if "battery unhealthy" in m.message.lower() and t - batt >= BATTERY_STALE_S - 0.5:
                audit.stale_battery_warnings.append((t, m.message.split("] ", 1)[-1].strip()))
    return audit


def apply_audit(files: list[Path], metrics: dict[str, float], events: list[Event]) -> LogAudit | None:
    """Audit the kept ``.ulg`` among ``files`` into the run: ``px4_scheduler_faults`` (stopped periodic topics),
    ``px4_battery_warnings`` without the warnings a stopped battery_status explains, and a ``px4_fault`` event.
    None (and nothing changed) without a readable ULog."""
    ulogs = [f for f in files if f.suffix == ".ulg"]
    if not ulogs:
        return None
    try:
        audit = audit_ulog(ulogs[-1])
    except Exception as exc:  # noqa: BLE001 - a log PX4 left unreadable (killed mid-write) is no run failure
        log.warning("cannot audit PX4's log %s: %s", ulogs[-1], exc)
        return None
    metrics["px4_scheduler_faults"] = float(len(audit.stops))
    if "px4_battery_warnings" in metrics and audit.stale_battery_warnings:
        metrics["px4_battery_warnings"] = max(0.0, metrics["px4_battery_warnings"] - len(audit.stale_battery_warnings))
    if audit.stops:
        first = min(s.last_s for s in audit.stops)
        data: dict[str, Any] = {"stopped": {s.topic: round(s.last_s, 3) for s in audit.stops},
                                "log_end_s": round(audit.stops[0].log_end_s, 3),
                                "battery_warnings": [w for _, w in audit.stale_battery_warnings]}
        events.append(Event(round(first * 1e6), "px4_fault", audit.describe(), data))
    return audit


__all__ = ["BATTERY_STALE_S", "PERIODIC_TOPICS", "STOP_GAP_S", "LogAudit", "TopicStop", "apply_audit", "audit_ulog"]
