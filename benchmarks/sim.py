"""Simulation-loop speed: one vehicle at 250 Hz with every model on, on mesh-tile terrain.

Models on: motor lag + thrust/torques, rotor drag and rolling moment, per-link wind drag,
Dryden turbulence (moderate) on a mean wind, tank draining at 0.05 L/s, IMU/baro/mag/GNSS
(depth camera off). The autopilot is a minimal hover PD controller on the truth (~3 µs per step),
so the figure is essentially the loop's own cost (the CI missions with the built-in autopilot and its
estimator, against the PyBullet floor and per part: ``benchmarks/loop_parts.py``). Reported:

* real-time factor of ``run_simulation`` (simulated s per wall s, loop only) and µs per step, also
  in process CPU time (what the loop would take on an otherwise idle core: the machine is shared);
* bare ``stepSimulation`` of the same body over the same tiles in the same process (gravity off
  so it floats at the same height without contact) in µs per step, and the ratio loop / bare;
* depth-camera cost per frame (ER_TINY_RENDERER) at 64×48 and 160×120 px over the tiles.

Usage::

    python benchmarks/sim.py            # 60 s simulated, 3 repeats
    python benchmarks/sim.py --quick    # smoke run: 5 s simulated, 1 repeat
    python benchmarks/sim.py --json out.json
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from vinecli.autopilot.base import AutopilotContext, AutopilotStatus  # noqa: E402
from vinecli.frames import quat_to_euler  # noqa: E402
from vinecli.types import ActuatorCommand, Event, Observation  # noqa: E402


class HoverPD:
    """Minimal hover controller from the truth (attitude PD + altitude PD, pseudo-inverse mixer),
    plain floats, ~3 µs per step: keeps the vehicle flying so the loop, not the autopilot, is timed."""

    name = "bench-hover-pd"

    def __init__(self, z_ref: float, flow_lps: float = 0.05) -> None:
        self.z_ref = z_ref
        self.flow = flow_lps

    def reset(self, ctx: AutopilotContext) -> None:
        import numpy as np

        v = ctx.vehicle
        fill = ctx.mission.tank_fill_l
        if fill is None:  # the bench knows its load: the mission's fill (default full)
            fill = v.tank.capacity_l if v.tank is not None else 0.0
        self.m = v.dry_mass() + v.liquid_mass(fill)
        self.k_f = v.motor.k_f
        self.w_max = v.motor.w_max
        self.n = v.n_rotors
        a = np.array([[1.0] * self.n, [r.position_m[1] for r in v.rotors], [-r.position_m[0] for r in v.rotors],
                      [-r.s * v.motor.k_m for r in v.rotors]])
        self.B = [tuple(float(x) for x in row) for row in np.linalg.pinv(a)]
        self.ixx, self.iyy, self.izz = v.frame.inertia_kgm2

    def step(self, obs: Observation) -> ActuatorCommand:
        tr = obs.truth
        roll, pitch, yaw = quat_to_euler(tr.quat)
        wx, wy, wz = tr.omega_body
        g = 9.80665
        c = max(0.5, math.cos(roll) * math.cos(pitch))
        fz = self.m * (g + 2.0 * (self.z_ref - tr.pos[2]) - 2.5 * tr.vel[2]) / c
        tx = self.ixx * (-40.0 * roll - 12.0 * wx)
        ty = self.iyy * (-40.0 * pitch - 12.0 * wy)
        tz = self.izz * (-4.0 * yaw - 2.0 * wz)
        k_f, w_max = self.k_f, self.w_max
        out = []
        for b0, b1, b2, b3 in self.B:
            t = b0 * fz + b1 * tx + b2 * ty + b3 * tz
            w = math.sqrt(t / k_f) if t > 0.0 else 0.0
            out.append(w if w < w_max else w_max)
        return ActuatorCommand(tuple(out), self.flow, True)

    def status(self) -> AutopilotStatus:
        return AutopilotStatus("bench", 0)

    def drain_events(self) -> list[Event]:
        return []

    def close(self) -> None:
        pass


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run (5 s simulated, 1 repeat)")
    ap.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per repeat")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", type=Path, help="write the figures as JSON")
    args = ap.parse_args(argv)
    seconds, repeats = (5.0, 1) if args.quick else (args.seconds, args.repeats)

    from vinecli.sim.camera import DepthCamera
    from vinecli.sim.runner import run_simulation
    from vinecli.specs.mission import MissionSpec
    from vinecli.world import build_world, load_world
    from vinecli.world.engine import Engine

    tmp = tempfile.TemporaryDirectory(prefix="vinecli-bench-")
    t0 = time.perf_counter()
    world = load_world(build_world(REPO / "worlds" / "vineyard-sample.yaml", Path(tmp.name) / "world"))
    build_s = time.perf_counter() - t0
    v = world.vehicle
    w_h = v.hover_speed(v.dry_mass() + v.liquid_mass(v.tank.capacity_l if v.tank else 0.0), world.gravity)
    x, y = 0.0, 0.0
    z_hover = world.terrain_height(x, y) + v.frame.landing_gear_height_m + 3.0
    mission = MissionSpec.model_validate({
        "name": "bench", "max_duration_s": seconds, "record_rate_hz": 50.0,
        "wind": {"law": {"type": "sum", "terms": [
            {"type": "constant", "velocity_enu": [2.0, 1.0, 0.0]},
            {"type": "dryden", "mean_mps": 3.0, "intensity": "moderate"}]}},
        "phases": [{"type": "open_loop", "duration_s": seconds, "rotor_speeds_rad_s": w_h,
                    "initial_state": {"position_enu": [x, y, 3.0]}}],
    })
    loop_us, rtf, loop_cpu_us = [], [], []
    for i in range(repeats):
        r = run_simulation(world, mission, HoverPD(z_hover), seed=i)
        assert r.status.value == "timeout", r.detail  # flew the whole duration
        loop_us.append(r.timing["wall_per_step_us"])
        loop_cpu_us.append(r.timing["cpu_per_step_us"])
        rtf.append(r.timing["real_time_factor"])
    steps = int(r.metrics["steps"])

    # bare stepSimulation: same tiles, same body, same height, gravity off (no contact)
    z = z_hover
    bare_us, bare_cpu_us = [], []
    with Engine(rate_hz=world.physics_rate_hz, gravity=0.0) as eng:
        eng.load_terrain(world.terrain)
        eng.load_vehicle(world.urdf, (x, y, z), (0.0, 0.0, 0.0, 1.0))
        step = eng.client.stepSimulation
        for _ in range(repeats):
            t, tc = time.perf_counter(), time.process_time()
            for _ in range(steps):
                step()
            bare_us.append((time.perf_counter() - t) / steps * 1e6)
            bare_cpu_us.append((time.process_time() - tc) / steps * 1e6)
        cam_ms = {}
        for wpx, hpx in ((64, 48), (160, 120)):
            spec = v.sensors.depth_camera.model_copy(update={"enabled": True, "width_px": wpx, "height_px": hpx})
            cam = DepthCamera(eng.client, spec, hide_body=eng.vehicle)
            n = 10 if args.quick else 50
            t = time.perf_counter()
            for k in range(n):
                cam.capture((x, y + 0.01 * k, z), (0.0, 0.0, 0.0, 1.0))
            cam_ms[f"{wpx}x{hpx}"] = (time.perf_counter() - t) / n * 1e3
    tmp.cleanup()

    res = {
        "simulated_s_per_repeat": seconds,
        "repeats": repeats,
        "physics_rate_hz": world.physics_rate_hz,
        "terrain": f"{world.terrain.kind}, {sum(f.suffix == '.obj' for f in world.terrain.files)} tiles",
        "loop_us_per_step": min(loop_us),
        "loop_us_per_step_median": statistics.median(loop_us),
        "real_time_factor": max(rtf),
        "loop_cpu_us_per_step": min(loop_cpu_us),
        "real_time_factor_cpu": 1e6 / world.physics_rate_hz / min(loop_cpu_us),
        "bare_step_us": min(bare_us),
        "bare_step_cpu_us": min(bare_cpu_us),
        "loop_over_bare_cpu": min(loop_cpu_us) / min(bare_cpu_us),
        "loop_over_bare": min(loop_us) / min(bare_us),
        "camera_ms_per_frame": cam_ms,
        "world_build_s": build_s,
        "target_real_time_factor": 100.0,
    }
    print(f"sim loop, 1 vehicle, {world.physics_rate_hz:g} Hz, all models on, {res['terrain']} "
          f"({seconds:g} s simulated × {repeats}):")
    print(f"  loop            {res['loop_us_per_step']:7.1f} µs/step  (median {res['loop_us_per_step_median']:.1f})"
          f"  -> real-time factor {res['real_time_factor']:.0f}× (target ≥ 100×)")
    print(f"  loop (CPU time) {res['loop_cpu_us_per_step']:7.1f} µs/step  -> real-time factor "
          f"{res['real_time_factor_cpu']:.0f}× if the CPU were ours alone")
    print(f"  bare step       {res['bare_step_us']:7.1f} µs/step  -> loop / bare = {res['loop_over_bare']:.1f}")
    print(f"  bare (CPU time) {res['bare_step_cpu_us']:7.1f} µs/step  -> loop / bare = {res['loop_over_bare_cpu']:.1f}")
    for k, ms in cam_ms.items():
        print(f"  depth camera    {ms:7.2f} ms/frame at {k}")
    print(f"  world build     {build_s:7.2f} s (vineyard-sample, DSM -> tiles)")
    if args.json:
        args.json.write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
