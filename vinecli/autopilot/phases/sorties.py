"""Ground operations of a refill job for the built-in spray phase: the energy bookkeeping that decides
when a sortie must return and whether the battery is swapped, and the ground service itself.

All from what a flight controller knows: the battery's state of charge (energy fraction) over time,
whether it is airborne, what it sprayed. Times s, energies as state-of-charge fractions, litres.

* :class:`EnergyLog` measures the mean power while airborne (state of charge used per airborne
  second) and, per sortie, the airborne time and the time spent spraying.
* A sortie returns when what is left above the reserve would no longer bring it home: the estimated
  return time (distance home at the transit speed, climb to the return height, descent) at the
  measured power, with a margin (:meth:`EnergyLog.must_return`).
* At each stop the battery is swapped when the next sortie (the measured overhead of a sortie plus the
  spraying time of the litres it will carry) could not land with the reserve
  (:meth:`EnergyLog.swap_needed`), or always / never as the job says.
* :class:`Service`: on the ground, disarmed, for the operations model's time
  (:meth:`~vinecli.specs.sprayer.OperationsSpec.ground_time_s`), then the crew refills (and swaps).
"""

from __future__ import annotations

import math

from vinecli.autopilot.phases.phase import Phase, PhaseHost
from vinecli.types import ServiceRequest

__all__ = ["ENERGY_MARGIN", "EnergyLog", "Service"]

#: the energy estimates are multiplied by this before they are compared with what is left
ENERGY_MARGIN = 1.25
_MIN_AIR_S = 5.0  # airborne seconds before the mean power is trusted


class EnergyLog:
    """Mean airborne power as state of charge per second, and the airborne / spraying time of each sortie."""

    def __init__(self) -> None:
        self.air_s = 0.0  # airborne time over the job, s
        self.used = 0.0  # state of charge used while airborne
        self._last_soc = math.nan
        self.sortie_air_s = 0.0  # this sortie
        self.sortie_spray_s = 0.0
        self.overheads: list[float] = []  # per finished sortie: airborne time not spent spraying, s

    @property
    def soc_per_s(self) -> float:
        """State of charge used per airborne second (NaN until enough flight)."""
        return self.used / self.air_s if self.air_s >= _MIN_AIR_S else math.nan

    def update(self, dt: float, airborne: bool, soc: float, spraying: bool) -> None:
        """Account ``dt`` s of the current state."""
        if soc == soc and self._last_soc == self._last_soc and airborne:
            self.air_s += dt
            self.used += max(self._last_soc - soc, 0.0)
            self.sortie_air_s += dt
            if spraying:
                self.sortie_spray_s += dt
        self._last_soc = soc

    def end_sortie(self) -> None:
        """The sortie landed: remember its overhead (airborne time not spent spraying)."""
        self.overheads.append(max(self.sortie_air_s - self.sortie_spray_s, 0.0))
        self.sortie_air_s = 0.0
        self.sortie_spray_s = 0.0

    def must_return(self, soc: float, reserve: float, return_s: float) -> bool:
        """True when the state of charge above ``reserve`` no longer covers ``return_s`` s of flight (with margin)."""
        rate = self.soc_per_s
        if rate != rate or soc != soc:
            return False
        return soc - reserve <= ENERGY_MARGIN * rate * return_s

    def swap_needed(self, soc: float, reserve: float, spray_s: float) -> tuple[bool, float]:
        """(swap?, predicted state of charge the next sortie uses): its spraying time ``spray_s`` plus the largest
        overhead of the sorties so far, at the measured power (with margin)."""
        rate = self.soc_per_s
        if rate != rate or soc != soc:
            return False, math.nan
        need = ENERGY_MARGIN * rate * (spray_s + max(self.overheads, default=0.0))
        return soc - need < reserve, need


class Service(Phase):
    """On the ground, disarmed: the crew refills the tank to ``fill_l`` (and swaps the battery) in ``time_s``."""

    MODE = "AUTO.LOITER"
    type = "service"

    def __init__(self, time_s: float, fill_l: float, swap: bool) -> None:
        self.time_s = time_s
        self.fill_l = fill_l
        self.swap = swap

    def start(self, ap: PhaseHost) -> None:
        self.t = 0.0
        self.requested = False

    def update(self, ap: PhaseHost, dt: float) -> bool:
        self.t += dt
        if self.t < self.time_s:
            return False
        if not self.requested:
            ap.request_service(ServiceRequest(self.fill_l, self.swap))
            self.requested = True
            return False
        return ap.tank_level_l >= self.fill_l - 1e-6
