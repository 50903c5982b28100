"""The ground-truth mode (mission ``truth: true``, ``run mission --truth``): the simulator hands the
built-in autopilot a perfect state estimate, as a motion-capture system feeds a real autopilot an
external odometry. The autopilot reads it through :class:`~vinecli.autopilot.estimate.StateEstimate`,
the interface its own estimator implements, and cannot tell them apart.
"""

from __future__ import annotations

from vinecli.autopilot.estimate import StateEstimate
from vinecli.types import Observation


class PerfectEstimator(StateEstimate):
    """The simulated vehicle's true state each step (world ENU, body FLU, SI): ready at once, no
    position uncertainty."""

    def __init__(self) -> None:
        super().__init__()
        self.ready = True
        self.not_ready_reason = ""

    def update(self, obs: Observation) -> None:
        """Copy the ground truth of this step."""
        tr = obs.truth
        self.pos, self.vel, self.acc = tr.pos, tr.vel, tr.acc
        self.quat, self.omega = tr.quat, tr.omega_body
