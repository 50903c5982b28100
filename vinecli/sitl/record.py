"""What a firmware run leaves for its run folder: the firmware's identity and the files kept from its
working directory (its own logs, ``.ulg`` / ``.BIN``, its console output, the parameter file it booted
with). A firmware backend fills :class:`FirmwareRecord` when it closes; ``run mission`` copies the files
into ``<run>/firmware/`` (listed in manifest.json) and writes the identity to summary.json ``firmware``."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vinecli.sitl.identity import FirmwareIdentity
from vinecli.types import Event

#: a firmware's check of its own kept logs: (kept files, the run's metrics, its events) -> findings; it adds
#: what it finds to the metrics and events (e.g. :func:`vinecli.sitl.px4.log_audit.apply_audit`)
LogAuditor = Callable[[list[Path], dict[str, float], list[Event]], Any]

#: the run-folder directory the firmware files go to
FIRMWARE_DIR = "firmware"


@dataclass
class FirmwareRecord:
    """Identity and kept files of one firmware run (the files live in :attr:`dir` until :meth:`discard`)."""

    identity: FirmwareIdentity
    dir: Path = field(default_factory=lambda: Path(tempfile.mkdtemp(prefix="vinecli-firmware-")))
    files: list[Path] = field(default_factory=list)
    auditor: LogAuditor | None = None

    def amend(self, metrics: dict[str, float], events: list[Event]) -> None:
        """Add what the firmware's own logs say about the firmware (:attr:`auditor`) to a run's metrics and events."""
        if self.auditor is not None:
            self.auditor(self.files, metrics, events)
            events.sort(key=lambda e: e.t_us)

    def summary(self) -> dict[str, Any]:
        """summary.json ``firmware``: the identity and the kept files (names under ``firmware/``)."""
        return {**self.identity.to_dict(), "files": [f"{FIRMWARE_DIR}/{f.name}" for f in self.files]}

    def copy_into(self, run_dir: Path) -> None:
        """Copy the kept files into ``run_dir/firmware/``."""
        if not self.files:
            return
        dest = run_dir / FIRMWARE_DIR
        dest.mkdir(parents=True, exist_ok=True)
        for f in self.files:
            shutil.copy2(f, dest / f.name)

    def discard(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)


def firmware_record(autopilot: object) -> FirmwareRecord | None:
    """What a firmware backend kept when it closed (its ``firmware_record``); None for any other autopilot."""
    record = getattr(autopilot, "firmware_record", None)
    return record if isinstance(record, FirmwareRecord) else None


__all__ = ["FIRMWARE_DIR", "FirmwareRecord", "LogAuditor", "firmware_record"]
