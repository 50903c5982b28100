"""What the loop hands the spray transport model: the sprayed volume in groups of steps.

While the sprayer runs, the volume that left the nozzles is summed over ``every`` steps (≈ 0.04 s,
``DepositionConfig.group_s``) and handed to ``emit`` as one record with the state of the group's last
step and the mean lag ``(n - 1) / 2`` steps of its volume (:data:`vinecli.spray.deposition.EMIT_COLUMNS`);
a group also ends when the flow stops, and the last one when the run ends (:meth:`SprayGroups.flush`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import final

from vinecli.frames import QuatXYZW, Vec3

__all__ = ["SprayGroups"]


@final
class SprayGroups:
    """Groups of ``every`` spraying steps of ``dt`` s each, handed to ``emit`` (module doc)."""

    def __init__(self, emit: Callable[[tuple[float, ...]], None], every: int, dt: float) -> None:
        self.emit = emit
        self.every = every
        self.dt = dt
        self.volume_l = 0.0
        self.n = 0
        # the state of the last step added (plain floats, no tuple per step)
        self.t = self.thrust_n = 0.0
        self.pos: Vec3 = (0.0, 0.0, 0.0)
        self.quat: QuatXYZW = (0.0, 0.0, 0.0, 1.0)
        self.vel: Vec3 = (0.0, 0.0, 0.0)
        self.wind: Vec3 = (0.0, 0.0, 0.0)

    def add(self, flow_lps: float, t: float, pos: Vec3, quat: QuatXYZW, vel: Vec3, wind: Vec3, thrust_n: float) -> None:
        """The step at ``t`` s sprayed ``flow_lps`` L/s (0: off) with the vehicle in this state (ENU, SI)."""
        dt = self.dt
        if flow_lps > 0.0:
            self.volume_l += flow_lps * dt
            self.n += 1
        self.t, self.pos, self.quat, self.vel, self.wind, self.thrust_n = t, pos, quat, vel, wind, thrust_n
        if self.n and (self.n >= self.every or flow_lps <= 0.0):
            self.flush()

    def flush(self) -> None:
        """Hand the open group (if any) to ``emit``: the state now; the volume left the nozzles on average
        (n - 1) / 2 steps earlier."""
        if self.n:
            px, py, pz = self.pos
            qx, qy, qz, qw = self.quat
            vx, vy, vz = self.vel
            wx, wy, wz = self.wind
            self.emit((self.t, px, py, pz, qx, qy, qz, qw, vx, vy, vz, wx, wy, wz, self.thrust_n, self.volume_l,
                       0.5 * (self.n - 1) * self.dt))
            self.volume_l = 0.0
            self.n = 0
