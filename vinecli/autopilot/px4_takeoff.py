"""``cannot_take_off`` for the PX4 backend: PX4 itself has no such detection.

Armed and not climbing (less than 0.5 m above where it armed, climbing slower than 0.3 m/s)
while either PX4's motor outputs stay near full (mean >= :data:`SATURATED_U`) for
``saturated_s`` (the vehicle's ``control.cannot_takeoff_s``), or the first takeoff phase's
``timeout_s`` has passed since arming without ever rising 0.5 m (PX4 backs off from full thrust
on the ground, so saturation alone is not always seen).
"""

from __future__ import annotations

from collections.abc import Sequence

SATURATED_U = 0.9  # mean motor output counted as "full thrust" (PX4 rarely holds 1.0 on the ground)


class TakeoffWatch:
    """Feed :meth:`update` every step; it returns the reason once the vehicle cannot take off."""

    def __init__(self, saturated_s: float, takeoff_timeout_s: float | None) -> None:
        self.saturated_s, self.takeoff_timeout_s = saturated_s, takeoff_timeout_s
        self._z0: float | None = None
        self._t0_us = 0
        self._sat_s = 0.0
        self._max_rise = 0.0

    def update(self, t_us: int, dt_s: float, armed: bool, z: float, vz: float, outputs: Sequence[float]) -> str:
        """'' while fine, else why the vehicle cannot take off (z, vz: truth, m and m/s up; outputs in [0, 1])."""
        if not armed:
            self._z0 = None
            self._sat_s = 0.0
            return ""
        if self._z0 is None:
            self._z0, self._t0_us, self._max_rise = z, t_us, 0.0
        rise = z - self._z0
        self._max_rise = max(self._max_rise, rise)
        mean_u = sum(outputs) / len(outputs) if outputs else 0.0
        if mean_u >= SATURATED_U and rise < 0.5 and vz < 0.3:
            self._sat_s += dt_s
        else:
            self._sat_s = 0.0
        waited = (t_us - self._t0_us) * 1e-6
        if self._sat_s >= self.saturated_s:
            return f"PX4 motor outputs saturated (mean {mean_u:.2f}) for {self._sat_s:.1f} s at {rise:.2f} m above the start"
        if self.takeoff_timeout_s is not None and waited > self.takeoff_timeout_s and self._max_rise < 0.5:
            return (f"no lift-off {waited:.1f} s after arming (takeoff timeout_s {self.takeoff_timeout_s:g} s) "
                    f"at {rise:.2f} m above the start")
        return ""


__all__ = ["SATURATED_U", "TakeoffWatch"]
