"""How a mission switches the sprayer: the MAVLink command the firmware understands, chosen by the caller.

* :data:`DO_SET_ACTUATOR` (PX4): MAV_CMD_DO_SET_ACTUATOR (187), param1 = flow / nozzle maximum in [0, 1]
  ("Peripheral via Actuator Set 1": an output joins it with ``PWM_xxx_FUNCn = 301``), params 2-6 NaN
  (unchanged), param7 = 0 (the set of actuators 1-6);
* :data:`DO_SPRAYER` (ArduPilot): MAV_CMD_DO_SPRAYER (216), param1 = 1 on, 0 off (the rate is the
  firmware's SPRAY_* parameters);
* :func:`do_set_servo` (ArduPilot or any PWM pump): MAV_CMD_DO_SET_SERVO (183), param1 = the output,
  param2 = PWM from ``pwm_off`` (no flow) to ``pwm_on`` (the nozzle maximum), linear.

:meth:`SprayerCommand.item` makes the item for a flow fraction; :func:`sprayer_fraction` reads any of the
three back (what :func:`vinecli.phase_items.items_to_phases` does with an uploaded mission).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vinecli.mavlink import px4modes as M
from vinecli.mavlink.mission_items import MissionItem

__all__ = ["DO_SET_ACTUATOR", "DO_SPRAYER", "SprayerCommand", "do_set_servo", "sprayer_fraction"]

NAN = math.nan


@dataclass(frozen=True)
class SprayerCommand:
    """One way of switching the sprayer (module doc). ``command`` is the MAV_CMD; ``servo``, ``pwm_off`` and
    ``pwm_on`` are used by DO_SET_SERVO only."""

    command: int
    servo: int = 0
    pwm_off: float = 1000.0
    pwm_on: float = 2000.0

    def item(self, fraction: float, phase_index: int = -1) -> MissionItem:
        """The mission item setting the flow to ``fraction`` (0..1) of the nozzle maximum."""
        u = min(max(float(fraction), 0.0), 1.0)
        if self.command == M.CMD_DO_SET_ACTUATOR:
            return MissionItem(self.command, M.MAV_FRAME_MISSION, u, NAN, NAN, NAN, 0, 0, 0.0, phase_index=phase_index)
        if self.command == M.CMD_DO_SPRAYER:
            return MissionItem(self.command, M.MAV_FRAME_MISSION, 1.0 if u > 0.0 else 0.0, phase_index=phase_index)
        if self.command == M.CMD_DO_SET_SERVO:
            pwm = self.pwm_off + u * (self.pwm_on - self.pwm_off)
            return MissionItem(self.command, M.MAV_FRAME_MISSION, float(self.servo), round(pwm), phase_index=phase_index)
        raise ValueError(f"MAV_CMD {self.command} does not switch a sprayer")


#: PX4: DO_SET_ACTUATOR, actuator set 1 (param1)
DO_SET_ACTUATOR = SprayerCommand(M.CMD_DO_SET_ACTUATOR)
#: ArduPilot: DO_SPRAYER on/off
DO_SPRAYER = SprayerCommand(M.CMD_DO_SPRAYER)


def do_set_servo(servo: int, pwm_off: float = 1000.0, pwm_on: float = 2000.0) -> SprayerCommand:
    """DO_SET_SERVO on output ``servo``: PWM ``pwm_off`` (no flow) to ``pwm_on`` (nozzle maximum), µs."""
    return SprayerCommand(M.CMD_DO_SET_SERVO, servo, pwm_off, pwm_on)


def sprayer_fraction(it: MissionItem, *, servo: int = 9, pwm_off: float = 1000.0, pwm_on: float = 2000.0,
                     sprayer_on: float = 1.0) -> float | None:
    """The flow fraction (0..1 of the nozzle maximum) a sprayer item sets; None when ``it`` is not one
    (another command, a DO_SET_SERVO of another output, a DO_SET_ACTUATOR with NaN = unchanged).
    ``sprayer_on``: the fraction DO_SPRAYER "on" stands for."""
    c = it.command
    if c == M.CMD_DO_SET_ACTUATOR:
        u = it.param1 if math.isfinite(it.param1) else None
    elif c == M.CMD_DO_SET_SERVO:
        if int(it.param1) != servo or not math.isfinite(it.param2):
            return None
        u = (it.param2 - pwm_off) / (pwm_on - pwm_off)
    elif c == M.CMD_DO_SPRAYER:
        u = sprayer_on if it.param1 >= 0.5 else 0.0
    else:
        return None
    return None if u is None else min(max(u, 0.0), 1.0)
