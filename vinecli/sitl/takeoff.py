"""``cannot_take_off`` for the firmware backends: neither PX4 nor ArduPilot reports one.

Armed and not climbing (less than 0.5 m above where it armed, climbing slower than 0.3 m/s)
while PX4's motor outputs stay near full (mean >= :data:`SATURATED_U`) for ``saturated_s`` (the
vehicle's ``control.cannot_takeoff_s``). PX4 backs off from full thrust on the ground (its
outputs peak at 0.92-0.94 and settle near 0.75 for an overloaded x500), so two more rules end a
take-off that never leaves the ground (never 0.5 m above the start): the outputs above half
(:data:`TRYING_U`, PX4 is trying to climb, not idling) for :data:`TRYING_S` in total, or the
first takeoff phase's ``timeout_s`` since arming. A healthy PX4 take-off rises 0.5 m about 2 s
after its outputs pass one half.
"""

from __future__ import annotations

from collections.abc import Sequence

SATURATED_U = 0.9  # mean motor output counted as "full thrust" (PX4 rarely holds 1.0 on the ground)
TRYING_U = 0.5  # mean motor output of a vehicle trying to climb (idle is ~0.1 while armed on the ground)
TRYING_S = 6.0  # s above TRYING_U without ever rising 0.5 m


class TakeoffWatch:
    """Feed :meth:`update` every step; it returns the reason once the vehicle cannot take off."""

    def __init__(self, saturated_s: float, takeoff_timeout_s: float | None, *, firmware: str = "PX4") -> None:
        self.saturated_s, self.takeoff_timeout_s = saturated_s, takeoff_timeout_s
        self.firmware = firmware
        self._z0: float | None = None
        self._t0_us = 0
        self._sat_s = 0.0
        self._trying_s = 0.0
        self._max_rise = 0.0

    def update(self, t_us: int, dt_s: float, armed: bool, z: float, vz: float, outputs: Sequence[float]) -> str:
        """'' while fine, else why the vehicle cannot take off (z, vz: truth, m and m/s up; outputs in [0, 1])."""
        if not armed:
            self._z0 = None
            self._sat_s = 0.0
            return ""
        if self._z0 is None:
            self._z0, self._t0_us, self._max_rise, self._trying_s = z, t_us, 0.0, 0.0
        rise = z - self._z0
        self._max_rise = max(self._max_rise, rise)
        mean_u = sum(outputs) / len(outputs) if outputs else 0.0
        if mean_u >= SATURATED_U and rise < 0.5 and vz < 0.3:
            self._sat_s += dt_s
        else:
            self._sat_s = 0.0
        if mean_u >= TRYING_U and self._max_rise < 0.5:
            self._trying_s += dt_s
        waited = (t_us - self._t0_us) * 1e-6
        if self._sat_s >= self.saturated_s:
            return f"{self.firmware} motor outputs saturated (mean {mean_u:.2f}) for {self._sat_s:.1f} s at {rise:.2f} m above the start"
        if self._trying_s >= TRYING_S:
            return (f"{self.firmware} motor outputs above {TRYING_U:g} for {self._trying_s:.1f} s without lifting off "
                    f"(now {mean_u:.2f}, {rise:.2f} m above the start)")
        if self.takeoff_timeout_s is not None and waited > self.takeoff_timeout_s and self._max_rise < 0.5:
            return (f"no lift-off {waited:.1f} s after arming (takeoff timeout_s {self.takeoff_timeout_s:g} s) "
                    f"at {rise:.2f} m above the start")
        return ""


__all__ = ["SATURATED_U", "TRYING_S", "TRYING_U", "TakeoffWatch"]
