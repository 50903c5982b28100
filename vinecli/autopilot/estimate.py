"""The one interface through which the built-in autopilot knows its own state.

:class:`StateEstimate` is what the controllers, the land detector and the failsafes read each
physics step: position, velocity and acceleration (world ENU), attitude (body FLU -> world ENU),
body rates (FLU), whether the estimate may be flown on, and its position uncertainty. The
autopilot's own estimator (:class:`vinecli.autopilot.estimator.Estimator`, from the simulated
sensors) implements it; so does the simulator's perfect estimator for ground-truth runs
(``vinecli.sim.perfect_estimator``, handed over in
:attr:`~vinecli.autopilot.base.AutopilotContext.estimator`, like an external motion-capture
odometry feed). The autopilot consumes either the same way.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

from mypy_extensions import mypyc_attr

from vinecli.frames import QuatXYZW, Vec3
from vinecli.types import Observation


@mypyc_attr(allow_interpreted_subclasses=True)  # compiled (vinecli/native.py)
class StateEstimate(ABC):
    """A state estimate, refreshed by :meth:`update` every physics step. World ENU, body FLU, SI.

    ``pos`` (m), ``vel`` (m/s), ``acc`` (m/s², gravity removed), ``quat`` (x, y, z, w), ``omega``
    (rad/s, body), ``ready`` (may be flown on; ``not_ready_reason`` says what it waits for),
    ``sigma_h_m`` / ``sigma_v_m`` (1-σ horizontal / vertical position uncertainty, m).
    """

    def __init__(self) -> None:
        self.pos: Vec3 = (0.0, 0.0, 0.0)
        self.vel: Vec3 = (0.0, 0.0, 0.0)
        self.acc: Vec3 = (0.0, 0.0, 0.0)
        self.quat: QuatXYZW = (0.0, 0.0, 0.0, 1.0)
        self.omega: Vec3 = (0.0, 0.0, 0.0)
        self.ready = False
        self.not_ready_reason = "no estimate yet"
        self.sigma_h_m = 0.0
        self.sigma_v_m = 0.0

    @abstractmethod
    def update(self, obs: Observation) -> None:
        """Take this step's observation (sensor samples; None for a sensor without a new one)."""
