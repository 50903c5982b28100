"""Array helpers the readers share: firmware NED/FRD arrays to vinecli's ENU/FLU (through
:mod:`vinecli.frames`, one sample at a time: the only module that flips signs), cleaned time bases,
normalised motor outputs and the battery's cell count."""

from __future__ import annotations

import math

import numpy as np

from vinecli.errors import InputError
from vinecli.frames import attitude_ned_frd_to_enu_flu, frd_to_flu, ned_to_enu, quat_from_euler

__all__ = ["attitude_from_euler_ned", "attitude_from_quat_ned", "cells_from_voltage", "frd_to_flu_array",
           "ned_to_enu_array", "normalise_outputs", "require", "sorted_stream"]

#: LiPo cell voltage range used to infer a pack's cell count from its rest voltage, V
CELL_V_RANGE = (3.3, 4.35)


def ned_to_enu_array(v: np.ndarray) -> np.ndarray:
    """(N, 3) world vectors NED -> ENU."""
    return np.array([ned_to_enu((a, b, c)) for a, b, c in np.asarray(v, dtype=float)]).reshape(-1, 3)


def frd_to_flu_array(v: np.ndarray) -> np.ndarray:
    """(N, 3) body vectors FRD -> FLU."""
    return np.array([frd_to_flu((a, b, c)) for a, b, c in np.asarray(v, dtype=float)]).reshape(-1, 3)


def attitude_from_quat_ned(q_wxyz: np.ndarray) -> np.ndarray:
    """(N, 4) attitudes q_NED<-FRD in (w, x, y, z) -> (N, 4) q_ENU<-FLU in (x, y, z, w)."""
    return np.array([attitude_ned_frd_to_enu_flu((x, y, z, w))
                     for w, x, y, z in np.asarray(q_wxyz, dtype=float)]).reshape(-1, 4)


def attitude_from_euler_ned(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Z-Y-X Euler angles of FRD in NED (rad) -> (N, 4) q_ENU<-FLU in (x, y, z, w)."""
    return np.array([attitude_ned_frd_to_enu_flu(quat_from_euler(r, p, y))
                     for r, p, y in zip(roll, pitch, yaw, strict=True)]).reshape(-1, 4)


def sorted_stream(t: np.ndarray, *arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """Samples with a finite time, sorted by time, duplicates of a time dropped (the first kept)."""
    t = np.asarray(t, dtype=float)
    ok = np.isfinite(t)
    order = np.argsort(t[ok], kind="stable")
    ts = t[ok][order]
    keep = np.concatenate(([True], np.diff(ts) > 0.0)) if len(ts) else np.zeros(0, bool)
    return (ts[keep], *(np.asarray(a)[ok][order][keep] for a in arrays))


def normalise_outputs(pwm: np.ndarray, pwm_min: float, pwm_max: float, pwm_disarmed: float) -> np.ndarray:
    """PWM µs -> u = (pwm - min) / (max - min) clipped to [0, 1]; NaN at or below the disarmed value."""
    pwm = np.asarray(pwm, dtype=float)
    u = np.clip((pwm - pwm_min) / (pwm_max - pwm_min), 0.0, 1.0)
    stop = max(pwm_disarmed, 0.0) + 0.5 * max(pwm_min - max(pwm_disarmed, 0.0), 0.0)
    u[~(pwm > stop)] = np.nan
    return u


def cells_from_voltage(v_rest: float) -> int | None:
    """Cells in series of a LiPo pack whose rest voltage is ``v_rest`` V (None when no count fits)."""
    if not math.isfinite(v_rest) or v_rest <= 0.0:
        return None
    lo, hi = CELL_V_RANGE
    fits = [n for n in range(1, 25) if lo <= v_rest / n <= hi]
    # the pack voltage alone can fit two counts (12.6 V = 3S full or 4S at 3.15 V): the nearest to 3.85 V
    return min(fits, key=lambda n: abs(v_rest / n - 3.85)) if fits else None


def require(ok: bool, path: str, what: str) -> None:
    """InputError (exit 2) naming the log and what it lacks when ``ok`` is false."""
    if not ok:
        raise InputError(what, path=path)
