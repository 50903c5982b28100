"""Land detection of the built-in autopilot from its own signals, as PX4's multicopter land detector
(``src/modules/land_detector/MulticopterLandDetector.cpp``, v1.15) does it.

Inputs each update (the position-loop rate): the estimated velocity (ENU m/s), body rates (FLU
rad/s) and acceleration (ENU m/s², gravity removed), the collective thrust setpoint normalised to
the maximum thrust, the hover thrust (the estimate when valid, else the nominal), the trajectory's
vertical velocity setpoint (ENU m/s; the descent the mission asks for) and the distance to the
ground when a rangefinder measures it. No ground truth.

Three states in sequence, each a hysteresis (:class:`Hysteresis`) that turns true only after its
conditions held for ``LNDMC_TRIG_TIME / 3`` (three times longer while a rangefinder exists but has
no valid distance) and false at once:

1. ``ground_contact``: low thrust (below 30 % of the way from the minimum to the hover thrust, 60 %
   with a valid hover thrust estimate), no vertical movement (``|vz| < LNDMC_Z_VEL_MAX``, 2.5x wider
   once landed), no horizontal movement (``< LNDMC_XY_VEL_MAX``), within 1 m of the ground when a
   rangefinder gives the distance, no climb over the last ``LNDMC_TRIG_TIME`` (the estimated altitude
   at most ``LNDMC_Z_VEL_MAX x LNDMC_TRIG_TIME`` above its lowest in that window: a bounce is no
   contact), and - until maybe-landed - a descent commanded (``-vz_sp >= 1.1 LNDMC_Z_VEL_MAX``). The
   position controller then drops to the minimum thrust.
2. ``maybe_landed``: ground contact, thrust at most 10 % of the way from the minimum to the hover
   thrust, no roll/pitch rotation (``< LNDMC_ROT_MAX``, 2.5x wider once landed), no free fall.
3. ``landed``: maybe-landed held for the same time again.

Free fall: specific force below 2 m/s² for 0.3 s. Disarmed, every state is true. Take-off is the
other direction: ``landed`` turns false as soon as the thrust rises above the maybe-landed level.
"""

from __future__ import annotations

import math
from typing import ClassVar

from vinecli.constants import STANDARD_GRAVITY
from vinecli.frames import Vec3

G = STANDARD_GRAVITY


class Hysteresis:
    """PX4 ``systemlib::Hysteresis``: a boolean that takes a requested value once the request has
    held for ``from_false_us`` (turning true) or ``from_true_us`` (turning false), integer µs."""

    def __init__(self, state: bool, from_false_us: int = 0, from_true_us: int = 0) -> None:
        self.state = state
        self.requested = state
        self.from_false_us = from_false_us
        self.from_true_us = from_true_us
        self._t_request_us = 0

    def set_state_and_update(self, new_state: bool, now_us: int) -> None:
        """Request ``new_state`` at ``now_us`` (the clock restarts when the request changes), then update."""
        if new_state != self.state:
            if new_state != self.requested:
                self.requested = new_state
                self._t_request_us = now_us
        else:
            self.requested = self.state
        self.update(now_us)

    def update(self, now_us: int) -> None:
        """Take the requested value if it held long enough by ``now_us``."""
        if self.requested != self.state:
            held = now_us - self._t_request_us
            if self.state and held >= self.from_true_us:
                self.state = False
            elif not self.state and held >= self.from_false_us:
                self.state = True


class LandDetector:
    """PX4's multicopter land detector (see the module docstring). Thrusts are normalised to the
    maximum collective thrust (0..1); ``thr_min`` is ``MPC_THR_MIN``."""

    FREEFALL_TRIGGER_US: ClassVar[int] = 300_000
    FREEFALL_ACC: ClassVar[float] = 2.0  # m/s², specific force below which the vehicle falls freely
    DIST_FROM_GROUND: ClassVar[float] = 1.0  # m, ground contact needs a measured distance below this
    HTE_VALID_US: ClassVar[int] = 1_000_000  # a hover thrust estimate counts as valid this long after its last valid value
    MIN_THRUST_8S_US: ClassVar[int] = 8_000_000
    CLIMB_SLOTS: ClassVar[int] = 10  # the climb window in slots of LNDMC_TRIG_TIME / 10

    def __init__(self, thr_min: float, hover_thrust: float, *, trig_time_s: float = 1.0, z_vel_max: float = 0.25,
                 xy_vel_max: float = 1.5, rot_max_deg: float = 20.0) -> None:
        self.thr_min = thr_min  # MPC_THR_MIN
        self.hover_param = hover_thrust  # MPC_THR_HOVER
        self.trig_us = int(round(trig_time_s * 1e6))  # LNDMC_TRIG_TIME
        self.z_vel_max = z_vel_max  # LNDMC_Z_VEL_MAX, m/s
        self.xy_vel_max = xy_vel_max  # LNDMC_XY_VEL_MAX, m/s
        self.rot_max = math.radians(rot_max_deg)  # LNDMC_ROT_MAX
        self.reset()

    def reset(self) -> None:
        """Back to the start-up state: on the ground (landed, maybe landed, ground contact)."""
        self.freefall_h = Hysteresis(False, self.FREEFALL_TRIGGER_US)
        self.ground_contact_h = Hysteresis(True)
        self.maybe_landed_h = Hysteresis(True)
        self.landed_h = Hysteresis(True)
        self.min_thrust_8s_h = Hysteresis(False, self.MIN_THRUST_8S_US)
        self._factor = 0
        self._set_factor(1)
        self.hover_thrust = self.hover_param
        self._hte_last_valid_us = -self.HTE_VALID_US
        self._hte_valid = False
        self.in_descend = False
        self.climbing = False
        self._z_ring = [math.inf] * self.CLIMB_SLOTS  # lowest altitude of each slot of the climb window, m
        self._slot = -1
        self.has_low_throttle = False
        self.vertical_movement = False
        self.horizontal_movement = False
        self.rotational_movement = False

    def set_flying(self) -> None:
        """In the air (a run that starts airborne): no ground contact, not landed."""
        for h in (self.ground_contact_h, self.maybe_landed_h, self.landed_h):
            h.state = h.requested = False

    def _set_factor(self, factor: int) -> None:
        """Hysteresis times of the three states: ``LNDMC_TRIG_TIME / 3 * factor``."""
        if factor != self._factor:
            self._factor = factor
            t = self.trig_us // 3 * factor
            self.ground_contact_h.from_false_us = t
            self.maybe_landed_h.from_false_us = t
            self.landed_h.from_false_us = t

    @property
    def ground_contact(self) -> bool:
        return self.ground_contact_h.state

    @property
    def maybe_landed(self) -> bool:
        return self.maybe_landed_h.state

    @property
    def landed(self) -> bool:
        return self.landed_h.state

    @property
    def freefall(self) -> bool:
        return self.freefall_h.state

    # parameters: called every physics step by compiled code with the estimate and the set points as plain
    # floats (PX4's land detector inputs): an object to hold them would be built every step
    def update(self, t_us: int, armed: bool, z: float, vel: Vec3, omega: Vec3, acc: Vec3, thrust: float,
               hover_estimate: float, hover_valid: bool, vz_sp: float, *, climb_rate_control: bool = True,
               dist_bottom: float = math.nan, range_observable: bool = False) -> None:
        """One update at ``t_us`` (see the module docstring): ``z`` estimated altitude (ENU m), ``vel``
        velocity (ENU m/s), ``omega`` body rates (FLU rad/s), ``acc`` acceleration (ENU m/s², gravity
        removed), ``thrust`` collective thrust setpoint (normalised). ``vz_sp``: the trajectory's vertical
        velocity setpoint, ENU m/s (NaN: none); ``dist_bottom``: distance to the ground measured by
        the rangefinder, m (NaN: no valid distance); ``range_observable``: the vehicle has one."""
        self._climb_window(t_us, z)
        if hover_valid:
            self.hover_thrust = hover_estimate
            self._hte_last_valid_us = t_us
        self._set_factor(3 if range_observable and dist_bottom != dist_bottom else 1)
        ax, ay, az = acc[0], acc[1], acc[2] + G
        self.freefall_h.set_state_and_update(ax * ax + ay * ay + az * az < self.FREEFALL_ACC * self.FREEFALL_ACC, t_us)
        self.ground_contact_h.set_state_and_update(
            self._ground_contact_state(t_us, armed, vel, thrust, vz_sp, climb_rate_control, dist_bottom), t_us)
        self.maybe_landed_h.set_state_and_update(self._maybe_landed_state(t_us, armed, omega, thrust, climb_rate_control),
                                                 t_us)
        self.landed_h.set_state_and_update(not armed or self.maybe_landed_h.state, t_us)

    def _climb_window(self, t_us: int, z: float) -> None:
        """Lowest altitude per slot over the last LNDMC_TRIG_TIME; ``climbing`` when ``z`` is more than
        LNDMC_Z_VEL_MAX x LNDMC_TRIG_TIME above the lowest."""
        ring = self._z_ring
        slot = t_us * self.CLIMB_SLOTS // self.trig_us
        if slot != self._slot:
            for k in range(self._slot + 1, min(slot, self._slot + self.CLIMB_SLOTS) + 1):
                ring[k % self.CLIMB_SLOTS] = math.inf  # slots that left the window
            self._slot = slot
        i = slot % self.CLIMB_SLOTS
        if z < ring[i]:
            ring[i] = z
        self.climbing = z - min(ring) > self.z_vel_max * self.trig_us * 1e-6

    def _ground_contact_state(self, t_us: int, armed: bool, vel: Vec3, thrust: float, vz_sp: float,
                              climb_rate_control: bool, dist_bottom: float) -> bool:
        vz_max = self.z_vel_max * (2.5 if self.landed_h.state else 1.0)
        self.vertical_movement = not abs(vel[2]) < vz_max
        self.horizontal_movement = vel[0] * vel[0] + vel[1] * vel[1] > self.xy_vel_max * self.xy_vel_max
        hte_valid = t_us - self._hte_last_valid_us < self.HTE_VALID_US
        if not self.in_descend or hte_valid:
            self._hte_valid = hte_valid  # a valid estimate that lapses during the descent is kept
        pct = 0.6 if self._hte_valid else 0.3
        self.has_low_throttle = thrust <= self.thr_min + (self.hover_thrust - self.thr_min) * pct
        contact = self.has_low_throttle
        if climb_rate_control:
            self.in_descend = -vz_sp >= 1.1 * self.z_vel_max  # NaN: False
            if not self.maybe_landed_h.state and not self.landed_h.state:
                contact = contact and self.in_descend  # ground contact needs a commanded descent until landed
        else:
            self.in_descend = False
        close = dist_bottom != dist_bottom or dist_bottom < self.DIST_FROM_GROUND
        return not armed or (close and contact and not self.horizontal_movement and not self.vertical_movement
                             and not self.climbing)

    def _maybe_landed_state(self, t_us: int, armed: bool, omega: Vec3, thrust: float, climb_rate_control: bool) -> bool:
        if climb_rate_control:
            threshold = self.thr_min + (self.hover_thrust - self.thr_min) * 0.1
        else:
            threshold = 0.08 + 0.01  # MPC_MANTHR_MIN + 0.01
        minimum_thrust = thrust <= threshold
        self.min_thrust_8s_h.set_state_and_update(minimum_thrust, t_us)
        rot_max = self.rot_max * (2.5 if self.landed_h.state else 1.0)
        self.rotational_movement = omega[0] * omega[0] + omega[1] * omega[1] > rot_max * rot_max
        return not armed or (minimum_thrust and not self.freefall_h.state and not self.rotational_movement
                             and self.ground_contact_h.state)
