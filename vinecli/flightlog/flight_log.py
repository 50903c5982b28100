"""The neutral flight log: what a PX4 ULog or an ArduPilot DataFlash log holds that a vehicle fit needs.

Every stream has its own time base ``t_s`` (seconds since the log's first sample, float64, strictly
increasing). Frames and units are vinecli's: world ENU, body FLU, quaternions ``(x, y, z, w)`` body ->
world, SI units (the readers convert the firmware's NED/FRD with :mod:`vinecli.frames`). Motor outputs
are kept as the firmware wrote them (PWM µs) and normalised to ``u`` in [0, 1] with the log's own output
range (``LogConfig.pwm_min_us``..``pwm_max_us``); ``u`` is NaN where the output is at or below the
disarmed value (motors stopped).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Attitude", "BatteryLog", "FlightLog", "Imu", "LocalPosition", "LogConfig", "LogInfo", "Motors",
           "StateLog", "gaps_of", "merged_gaps"]


@dataclass(frozen=True)
class Motors:
    """Motor outputs: ``pwm_us`` (N, n) as written; ``u`` (N, n) normalised, NaN when stopped."""

    t_s: np.ndarray
    pwm_us: np.ndarray
    u: np.ndarray


@dataclass(frozen=True)
class Imu:
    """Specific force ``accel_flu`` (N, 3) m/s² (level at rest: (0, 0, +g)) and ``gyro_flu`` (N, 3) rad/s."""

    t_s: np.ndarray
    accel_flu: np.ndarray
    gyro_flu: np.ndarray


@dataclass(frozen=True)
class Attitude:
    """Body attitude ``quat_xyzw`` (N, 4), body FLU -> world ENU (the firmware's estimate)."""

    t_s: np.ndarray
    quat_xyzw: np.ndarray


@dataclass(frozen=True)
class LocalPosition:
    """Estimated position ``pos_enu`` (N, 3) m from the estimator's origin and velocity ``vel_enu`` (N, 3) m/s."""

    t_s: np.ndarray
    pos_enu: np.ndarray
    vel_enu: np.ndarray


@dataclass(frozen=True)
class BatteryLog:
    """Pack terminal ``voltage_v`` (N,) V and ``current_a`` (N,) A (NaN where the log has no current)."""

    t_s: np.ndarray
    voltage_v: np.ndarray
    current_a: np.ndarray


@dataclass(frozen=True)
class StateLog:
    """Armed and landed flags as step functions: the value at ``t_s[i]`` holds until ``t_s[i + 1]``."""

    t_s: np.ndarray
    armed: np.ndarray
    landed: np.ndarray

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(armed, landed) boolean arrays at times ``t`` (s); before the first change: the first value."""
        i = np.clip(np.searchsorted(self.t_s, t, side="right") - 1, 0, len(self.t_s) - 1)
        return self.armed[i].astype(bool), self.landed[i].astype(bool)


@dataclass(frozen=True)
class LogInfo:
    """Where the log came from: file, format, firmware, hardware, flight date (UTC ISO date or None)."""

    path: str
    format: str  # "ulog" | "dataflash"
    firmware: str
    hardware: str
    date_utc: str | None
    duration_s: float
    sha256: str


@dataclass(frozen=True)
class LogConfig:
    """The firmware's parameters a fit needs (None: the log does not say).

    ``hover_throttle`` is the firmware's own hover value (PX4 MPC_THR_HOVER / hover_thrust_estimate,
    ArduPilot MOT_THST_HOVER / THR_MID) in its normalised thrust, ``thrust_expo`` its thrust-curve
    model (PX4 THR_MDL_FAC, ArduPilot MOT_THST_EXPO), each with the parameter it came from.
    """

    n_motors: int
    pwm_min_us: float
    pwm_max_us: float
    pwm_disarmed_us: float
    frame: str
    cells: int | None = None
    capacity_mah: float | None = None
    hover_throttle: float | None = None
    hover_throttle_source: str = ""
    thrust_expo: float | None = None
    thrust_expo_source: str = ""
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class FlightLog:
    """One flight log in vinecli's frames and units (module docstring)."""

    info: LogInfo
    config: LogConfig
    motors: Motors
    imu: Imu
    attitude: Attitude
    position: LocalPosition
    battery: BatteryLog | None
    state: StateLog
    params: dict[str, float] = field(default_factory=dict)
    #: intervals (t0, t1) s where the motor outputs or the IMU have no samples (logger dropouts, cuts)
    gaps: tuple[tuple[float, float], ...] = ()

    def summary(self) -> dict[str, Any]:
        """A JSON-able description: source, configuration, streams (samples and rates), gaps."""
        def rate(t: np.ndarray) -> float:
            return float((len(t) - 1) / (t[-1] - t[0])) if len(t) > 1 and t[-1] > t[0] else math.nan

        streams = {"motors": self.motors.t_s, "imu": self.imu.t_s, "attitude": self.attitude.t_s,
                   "position": self.position.t_s, "state": self.state.t_s}
        if self.battery is not None:
            streams["battery"] = self.battery.t_s
        return {
            "path": self.info.path, "format": self.info.format, "firmware": self.info.firmware,
            "hardware": self.info.hardware, "date_utc": self.info.date_utc, "sha256": self.info.sha256,
            "duration_s": self.info.duration_s, "frame": self.config.frame, "n_motors": self.config.n_motors,
            "pwm_range_us": [self.config.pwm_min_us, self.config.pwm_max_us],
            "streams": {k: {"samples": len(t), "rate_hz": rate(t)} for k, t in streams.items()},
            "gaps_s": [list(g) for g in self.gaps],
            "notes": list(self.config.notes),
        }


def merged_gaps(*gap_lists: list[tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    """Gap intervals of several streams merged where they overlap, sorted."""
    out: list[tuple[float, float]] = []
    for a, b in sorted(g for gl in gap_lists for g in gl):
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return tuple(out)


def gaps_of(t: np.ndarray, *, factor: float = 5.0, min_s: float = 0.5) -> list[tuple[float, float]]:
    """Intervals between consecutive samples longer than ``factor`` times the median step and ``min_s`` s."""
    if len(t) < 3:
        return []
    d = np.diff(t)
    limit = max(factor * float(np.median(d)), min_s)
    return [(float(t[i]), float(t[i + 1])) for i in np.flatnonzero(d > limit)]
