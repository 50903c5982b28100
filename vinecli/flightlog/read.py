"""Open any supported flight log by its first bytes: PX4 ULog or ArduPilot DataFlash ``.bin``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vinecli.errors import InputError
from vinecli.flightlog.flight_log import FlightLog
from vinecli.outputs import sha256_file

__all__ = ["ULOG_MAGIC", "DATAFLASH_MAGIC", "read_flight_log"]

ULOG_MAGIC = b"ULog\x01\x12\x35"
DATAFLASH_MAGIC = b"\xa3\x95"
#: fewest samples of each required stream a log must hold to be used
MIN_SAMPLES = 10


def read_flight_log(path: str | Path) -> FlightLog:
    """Read a ``.ulg`` or DataFlash ``.bin`` into vinecli's frames and units.

    InputError (exit 2) naming the file and the problem when it is missing, empty, of another kind,
    truncated before its data, or lacks a stream a fit needs (motor outputs, IMU, attitude, local position).
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("flight log not found" if not p.exists() else "not a file", path=p)
    try:
        with open(p, "rb") as f:
            head = f.read(16)
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror}", path=p) from None
    if not head:
        raise InputError("empty file, not a flight log", path=p)
    digest = sha256_file(p)
    if head.startswith(ULOG_MAGIC):
        from vinecli.flightlog.ulog import read_ulog

        log = read_ulog(str(p), digest)
    elif head.startswith(DATAFLASH_MAGIC):
        from vinecli.flightlog.dataflash import read_dataflash

        log = read_dataflash(str(p), digest)
    else:
        raise InputError(f"not a PX4 ULog or ArduPilot DataFlash log (starts with {head[:8]!r})", path=p)
    _check(log, str(p))
    return log


def _check(log: FlightLog, path: str) -> None:
    """Every required stream has enough finite samples."""
    streams = {"motor-output": (log.motors.t_s, log.motors.pwm_us), "IMU": (log.imu.t_s, log.imu.accel_flu),
               "attitude": (log.attitude.t_s, log.attitude.quat_xyzw),
               "local-position": (log.position.t_s, log.position.vel_enu)}
    for name, (t, v) in streams.items():
        good = np.isfinite(v).all(axis=1).sum() if len(t) else 0
        if good < MIN_SAMPLES:
            raise InputError(f"too few {name} samples ({good}; the log is truncated or the topic is not logged)",
                             path=path)
