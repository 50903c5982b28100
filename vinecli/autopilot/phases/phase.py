"""One step of a built-in autopilot mission (:class:`Phase`) and what it may use of the autopilot
(:class:`PhaseHost`, implemented by :class:`~vinecli.autopilot.builtin.BuiltinAutopilot`).

A phase reads the estimated state (world ENU, SI units) and commands position setpoints, the
sprayer flow and arming through the host; it never touches the controllers' outputs. The phases
of a mission are built by :func:`vinecli.autopilot.phases.from_spec.make_phase`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Protocol

from mypy_extensions import mypyc_attr

from vinecli.autopilot.geofence import Geofence
from vinecli.control.cascade import Cascade
from vinecli.frames import Vec3
from vinecli.specs.vehicle import VehicleSpec
from vinecli.types import ServiceRequest


class PhaseHost(Protocol):
    """The autopilot as a phase sees it: estimated state (world ENU, SI) and the commands it may give."""

    t_us: int  # time of the current step, µs
    vehicle: VehicleSpec
    home: Vec3  # ENU m, where the vehicle started (altitudes *_agl_m are above its z)
    pos: Vec3  # estimated position, ENU m
    vel: Vec3  # estimated velocity, ENU m/s
    mass: float  # mass the controllers fly with: from the hover thrust estimate, kg
    armed: bool
    airborne: bool  # take-off detected (not landed, 0.2 m above the ground) since arming or the last landing
    ground_contact: bool  # the land detector's ground contact
    landed: bool  # the land detector's landed state
    idle: bool  # armed with the rotors at idle speed (spool-up, waiting on the ground)
    mode: str  # PX4 mode name
    flow: float  # sprayer flow command, L/s
    tank_level_l: float
    tank_empty: bool
    battery_soc: float  # state of charge 0..1 (NaN: no battery model)
    sortie: int  # 1-based sortie of a refill job
    spool_s: float  # rotor spool-up before take-off, s
    cascade: Cascade
    geofence: Geofence | None
    terrain: Callable[[float, float], float]  # terrain z (ENU m) at (x, y)

    @property
    def rotor_command(self) -> tuple[float, ...]:
        """The last rotor speed command, rad/s per rotor."""
        ...

    def preflight_ok(self) -> bool:
        """True when the vehicle may arm now (a failed check ends the run)."""
        ...

    def arm(self) -> None:
        """Arm (motors idle)."""
        ...

    def disarm(self) -> None:
        """Disarm (motors off, sprayer off)."""
        ...

    def emit(self, kind: str, message: str, data: dict[str, object] | None = None) -> None:
        """Queue an event at the current time."""
        ...

    def set_flow(self, flow: float) -> None:
        """Sprayer flow command, L/s."""
        ...

    def hold_sp(self) -> Vec3:
        """Where to hold: the last position setpoint, else the current estimate (ENU m)."""
        ...

    def set_position(self, sp: Vec3, vff: Vec3, *, z_velocity_only: bool = False,
                     aff: Vec3 = (0.0, 0.0, 0.0)) -> None:
        """Position setpoint (ENU m) with velocity (m/s) and acceleration (m/s²) feed-forward."""
        ...

    def request_service(self, req: ServiceRequest) -> None:
        """Ask the ground crew to refill / swap the battery (honoured while disarmed on the ground)."""
        ...

    def abort(self, detail: str) -> None:
        """Abandon the mission: return home and land (at once when on the ground), then end the run ``aborted``."""
        ...


@mypyc_attr(allow_interpreted_subclasses=True)  # compiled (vinecli/native.py); MAVLink phases subclass it
class Phase(ABC):
    """One step of the mission; ``update`` runs at the position-loop rate, returns True when done.

    ``mode`` is the PX4 mode name while the phase runs (``MODE`` of the class unless the phase
    decides it), ``type`` its name in ``phase`` events, ``timeout_s`` how long it may run before
    the run ends ``timeout`` (s).
    """

    MODE = "AUTO.LOITER"
    type = ""
    timeout_s = math.inf

    @property
    def mode(self) -> str:
        """The PX4 mode name while the phase runs."""
        return self.MODE

    def start(self, ap: PhaseHost) -> None:
        """Called once when the phase becomes active (default: remember when)."""
        self.t_start_us = ap.t_us

    @abstractmethod
    def update(self, ap: PhaseHost, dt: float) -> bool:
        """Set the setpoints for the next ``dt`` s; True when the phase is complete."""
