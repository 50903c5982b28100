"""Helpers for tests/sim: a trivial open-loop autopilot (Autopilot protocol), missions, world files."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from vinecli.autopilot.base import AutopilotContext, AutopilotStatus, RunStatus
from vinecli.specs.mission import MissionSpec
from vinecli.types import ActuatorCommand, Event, Observation


class OpenLoop:
    """Autopilot protocol with open-loop rotor commands: ``fn(obs) -> speeds`` (rad/s per rotor)."""

    name = "open-loop-test"

    def __init__(self, fn: Callable[[Observation], Sequence[float]], flow_lps: float = 0.0,
                 done_after_s: float | None = None) -> None:
        self.fn = fn
        self.flow = flow_lps
        self.done_after_us = None if done_after_s is None else int(done_after_s * 1e6)
        self.ctx: AutopilotContext | None = None
        self.t_us = 0
        self.observations = 0

    def reset(self, ctx: AutopilotContext) -> None:
        self.ctx = ctx

    def step(self, obs: Observation) -> ActuatorCommand:
        self.t_us = obs.t_us
        self.observations += 1
        return ActuatorCommand(tuple(float(w) for w in self.fn(obs)), self.flow, True)

    def status(self) -> AutopilotStatus:
        if self.done_after_us is not None and self.t_us >= self.done_after_us:
            return AutopilotStatus("test", 0, RunStatus.COMPLETED, "done")
        return AutopilotStatus("test", 0)

    def drain_events(self) -> list[Event]:
        return []

    def close(self) -> None:
        pass


class AltitudeHold(OpenLoop):
    """Collective-only PI on vertical speed/height from the truth; knows nothing about the mass."""

    def __init__(self, n: int, w0: float, z_target: float) -> None:
        self.integral = w0
        self.z_target = z_target
        super().__init__(self._cmd)
        self.n = n

    def _cmd(self, obs: Observation) -> list[float]:
        ez = self.z_target - obs.truth.pos[2]
        ev = 0.5 * ez - obs.truth.vel[2]
        self.integral += 40.0 * ev * 0.004
        return [self.integral + 80.0 * ev] * self.n


def mission(phases: list[dict[str, Any]] | None = None, **kw: Any) -> MissionSpec:
    """A MissionSpec from keyword fields (default: one 2 s open-loop phase)."""
    d: dict[str, Any] = {"name": "t", "max_duration_s": 2.0, "record_rate_hz": 250.0}
    d.update(kw)
    d["phases"] = phases or [{"type": "open_loop", "duration_s": d["max_duration_s"], "rotor_speeds_rad_s": 0.0}]
    return MissionSpec.model_validate(d)


def world_yaml(tmp: Path, terrain: dict[str, Any], **kw: Any) -> Path:
    import yaml

    d: dict[str, Any] = {"name": "t", "terrain": terrain, "vehicle": "x500-sprayer"}
    d.update(kw)
    p = tmp / "world.yaml"
    p.write_text(yaml.safe_dump(d))
    return p
