"""The sprayer's flow command as flown: speed-scaled with on/off hysteresis (plain floats, per step).

As ArduPilot's AC_Sprayer (libraries/AC_Sprayer/AC_Sprayer.cpp): while a section is open over the
target, the pump command follows the horizontal ground speed,
``flow = litres per metre x speed`` (SPRAY_PUMP_RATE x speed in AC_Sprayer), so the litres per
hectare stay constant when the vehicle speeds up or slows down; it is at most the pump's maximum.
The pump runs only once the speed has stayed at or above ``speed_min`` for ``on_delay`` (100 ms
in AC_Sprayer) and stops once it has stayed below for ``off_delay`` (1000 ms); an unknown speed
(NaN) counts as 0. The sections (section control of commercial sprayer drones: closed in turns,
headlands, over rows done and outside the field) open and close the valves at once; the speed
timers run whatever the sections do, so a section opening at spraying speed sprays at once.
"""

from __future__ import annotations

from vinecli.specs.sprayer import SprayControlSpec

__all__ = ["SpeedScaledSprayer"]


class SpeedScaledSprayer:
    """Flow command (L/s) from the ground speed (m/s), the litres per metre asked and whether a section is open."""

    def __init__(self, spec: SprayControlSpec, max_flow_lps: float) -> None:
        self.speed_min = float(spec.speed_min_mps)
        self.on_delay = float(spec.on_delay_s)
        self.off_delay = float(spec.off_delay_s)
        self.max_flow_lps = float(max_flow_lps)
        #: the pump is running (past the on-delay, not yet past the off-delay)
        self.spraying = False
        self._above_s = 0.0  # time the speed has been at or above the minimum, s
        self._below_s = 0.0  # time it has been below, s
        #: last flow command, L/s
        self.flow_lps = 0.0

    def reset(self) -> None:
        """Pump off, timers cleared (a new flight)."""
        self.spraying = False
        self._above_s = 0.0
        self._below_s = 0.0
        self.flow_lps = 0.0

    def update(self, dt: float, speed_mps: float, litres_per_m: float, section_open: bool) -> float:
        """Advance ``dt`` s; returns the flow command, L/s (0 while off)."""
        v = speed_mps if speed_mps == speed_mps else 0.0  # NaN: velocity unknown -> 0
        if v >= self.speed_min:
            self._above_s += dt
            self._below_s = 0.0
            if not self.spraying and self._above_s >= self.on_delay:
                self.spraying = True
        else:
            self._below_s += dt
            self._above_s = 0.0
            if self.spraying and self._below_s >= self.off_delay:
                self.spraying = False
        q = litres_per_m * v if self.spraying and section_open and litres_per_m > 0.0 else 0.0
        if q > self.max_flow_lps:
            q = self.max_flow_lps
        self.flow_lps = q
        return q
