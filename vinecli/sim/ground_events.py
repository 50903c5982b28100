"""Ground contact and the events the simulator detects from it (the truth, not the autopilot's view).

* contact: the vehicle body touches the terrain when a contact point carried a normal force in the last
  step or is closer than :data:`TOUCH_M` (PyBullet also lists points a few mm apart within its contact
  threshold); queried only when the skids are within :data:`CONTACT_MARGIN_M` of the grid height;
* ``liftoff``: no contact for :data:`DEBOUNCE_S` with the rotors carrying at least
  :data:`LIFTOFF_THRUST_FRAC` of the weight when contact was lost (a bounce or a tumble with idle
  motors is none); ``touchdown``: contact again for :data:`DEBOUNCE_S` after a lift-off;
* ``crash``: first contact with a vertical speed above the crash speed (every first contact's speed is
  an impact: metric ``max_impact_speed_mps``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, final

from vinecli.types import Event

__all__ = ["CONTACT_MARGIN_M", "DEBOUNCE_S", "LIFTOFF_THRUST_FRAC", "TOUCH_M", "GroundEvents", "touching"]

DEBOUNCE_S = 0.05  # s of (no) contact before lift-off / touchdown is declared
LIFTOFF_THRUST_FRAC = 0.5  # rotor thrust / weight when contact is lost, for that to count as a lift-off
CONTACT_MARGIN_M = 0.6  # m: contacts are queried only when the skids are this close to the grid height
TOUCH_M = 1e-4  # m: a contact point closer than this counts as touching


def touching(contacts: Callable[..., Any], body: int, client: int) -> bool:
    """True when PyBullet's contact points of ``body`` (``getContactPoints``) show it on the ground (module doc)."""
    for cp in contacts(body, -1, -2, -2, client):
        if cp[9] > 0.0 or cp[8] <= TOUCH_M:
            return True
    return False


@final
class GroundEvents:
    """The lift-off / touchdown / crash detector (module doc); events go to ``events``, times and impact
    speeds to ``metrics`` (``liftoff_s``, ``touchdown_s``, ``max_impact_speed_mps``)."""

    def __init__(self, debounce_steps: int, airborne: bool, crash_speed_mps: float, events: list[Event],
                 metrics: dict[str, float]) -> None:
        self.debounce = debounce_steps
        self.airborne = airborne
        self.crash_speed = crash_speed_mps
        self.events = events
        self.metrics = metrics
        self.flips = 0  # steps the contact has differed from the state
        self.flip_t_us = 0
        self.flip_lifting = False
        self.impact_pending = True  # the next first contact is an impact to measure
        self.impact_mps = 0.0  # vertical speed of the last crash

    def update(self, on_ground: bool, t_us: int, vz_before: float, z: float, lifting: bool) -> bool:
        """One step: contact now (``on_ground``) at ``t_us``, vertical speed before it (m/s), CoM height (m),
        ``lifting``: the rotors carry at least the lift-off fraction of the weight. True on a crash."""
        crashed = False
        if on_ground != (not self.airborne):
            if self.flips == 0:
                self.flip_t_us = t_us
                self.flip_lifting = lifting
            self.flips += 1
            if on_ground and self.impact_pending:
                self.impact_pending = False
                crashed = self._impact(t_us, -vz_before)
            if self.flips >= self.debounce and not on_ground and not (self.flip_lifting or lifting):
                self.impact_pending = True  # off the ground without thrust (bounce, tumble): no lift-off event
            elif self.flips >= self.debounce:
                self._switch(not on_ground, z)
        else:
            self.flips = 0
            if not on_ground:
                self.impact_pending = True
        return crashed

    def _impact(self, t_us: int, speed: float) -> bool:
        if speed > self.metrics["max_impact_speed_mps"]:
            self.metrics["max_impact_speed_mps"] = speed
        if speed > self.crash_speed:
            self.events.append(Event(t_us, "crash", f"hard impact at {speed:.2f} m/s vertical", {"impact_speed_mps": speed}))
            self.impact_mps = speed
            return True
        return False

    def _switch(self, airborne: bool, z: float) -> None:
        self.airborne = airborne
        self.flips = 0
        t_us = self.flip_t_us
        ts = t_us * 1e-6
        if airborne:
            self.impact_pending = True
            self.events.append(Event(t_us, "liftoff", f"lift-off at {ts:.3f} s", {"z_m": z}))
            if math.isnan(self.metrics["liftoff_s"]):
                self.metrics["liftoff_s"] = ts
        else:
            self.events.append(Event(t_us, "touchdown", f"touchdown at {ts:.3f} s", {"z_m": z}))
            self.metrics["touchdown_s"] = ts
