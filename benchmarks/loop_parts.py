"""The CI missions' loop against the PyBullet floor, in one run, with the cost of each part.

For each mission (built-in autopilot, estimator on, every physics model, the sample world's 27
mesh tiles) it reports, all in process CPU time per 250 Hz step (robust to other processes, not to a virtual
machine's neighbours: where the floor itself moves from run to run, ``loop_instructions.py`` counts instead):

* **loop**: ``summary.json timing.cpu_per_step_us`` of a ``run_mission`` in this process, with the
  kernel this process runs (``vinecli.native.state``: ``compiled`` after ``make native``);
* **reference**: the same loop on the pure-Python sources (``VINECLI_PURE_PYTHON=1``, a subprocess),
  and the kernel's speed-up over it;
* **floor**: what any loop must pay PyBullet per step, measured here on the same world and body:
  ``stepSimulation`` + ``getBasePositionAndOrientation`` + ``getBaseVelocity`` + one
  ``applyExternalForce`` + one ``applyExternalTorque`` (gravity off, floating, no contact);
* **loop / floor** (the issue's target: <= 2.5) and the loop's real-time factor;
* **whole case in a warm worker**: a second ``run_mission`` of the mission in this process, as a batch
  worker runs its next case (terrain kept loaded; reading the specs, the run, checks and writing the
  run directory included): simulated s / wall s;
* **whole process**: ``vinecli run mission`` as a subprocess (Python start-up, imports, world load,
  recording and writing included): simulated s / wall s, best of 3 (bytecode cached, Python's default);
  next to it the bound that start-up alone sets: simulated s / (importing the chosen dependencies a run
  needs, ``numpy pybullet pydantic typer yaml pyarrow.parquet``, in a bare interpreter + loading the
  world's terrain into PyBullet + the loop itself), i.e. what a run could reach if vinecli's own
  imports, set-up, checks and writing cost nothing;
* **parts** (``--parts``): a cProfile of the mission's loop only on the pure-Python reference (cProfile
  does not see inside compiled code), self time grouped by owner (PyBullet, physics models, sensors,
  estimator, control + phases, recorder, loop body, other), scaled to the reference's CPU per step.
  Profiling inflates Python calls more than C calls, so these are shares to rank work by.

    .venv/bin/python benchmarks/loop_parts.py [--missions gust spray] [--parts] [--json out.json]
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

#: owner of a function, by the path of its source file (first match wins); C functions by name below
PARTS: list[tuple[str, str]] = [
    ("vinecli/flight/sensors", "sensors"),
    ("vinecli/flight/", "physics models"),
    ("vinecli/autopilot/estimator", "estimator"),
    ("vinecli/control/", "control + phases"),
    ("vinecli/autopilot/", "control + phases"),
    ("vinecli/sim/recorder", "recorder"),
    ("vinecli/sim/vehicle_physics", "physics models"),
    ("vinecli/sim/", "loop body"),
    ("vinecli/frames", "frames (shared)"),
    ("vinecli/types", "types (shared)"),
]
PYBULLET_CALLS = ("stepSimulation", "getBasePositionAndOrientation", "getBaseVelocity", "applyExternalForce",
                  "applyExternalTorque", "getContactPoints", "rayTest", "getJointState", "getLinkState",
                  "resetBaseVelocity", "resetBasePositionAndOrientation")


#: times floor_us runs its floor loop (it keeps the best)
FLOOR_REPEATS = 3


def floor_us(world: Any, steps: int, *, on_ground: bool = False) -> float:
    """CPU µs per step of the PyBullet floor (step + state reads + one force + one torque): floating with
    gravity off, or (``on_ground``) resting on the terrain at the spawn under gravity, where PyBullet also
    solves the skids' contacts with the mesh every step."""
    from vinecli.world.engine import Engine

    x, y = world.spawn_enu[0], world.spawn_enu[1]
    z = world.terrain_height(x, y) + (0.3 if on_ground else 3.0)
    with Engine(rate_hz=world.physics_rate_hz, gravity=world.gravity if on_ground else 0.0) as eng:
        eng.load_terrain(world.terrain)
        body = eng.load_vehicle(world.urdf, (x, y, z), (0.0, 0.0, 0.0, 1.0))
        p = eng.client
        step, pose, vel = p.stepSimulation, p.getBasePositionAndOrientation, p.getBaseVelocity
        force, torque, frame = p.applyExternalForce, p.applyExternalTorque, p.WORLD_FRAME
        for _ in range(500 if on_ground else 0):  # come to rest on the skids
            step()
        best = float("inf")
        for _ in range(FLOOR_REPEATS):
            t = time.process_time()
            for _ in range(steps):
                pose(body)
                vel(body)
                force(body, -1, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), frame)
                torque(body, -1, (0.0, 0.0, 0.0), frame)
                step()
            best = min(best, (time.process_time() - t) / steps * 1e6)
        if on_ground:
            assert p.getContactPoints(bodyA=body), "the floor on the ground has no contact"
    return best


def part_of(filename: str, funcname: str) -> str:
    """The owner of one profiled function."""
    if filename == "~":
        return "PyBullet" if any(c in funcname for c in PYBULLET_CALLS) else "builtins (math, list...)"
    for prefix, part in PARTS:
        if prefix in filename:
            return part
    return "other (numpy, pydantic...)"


def profile_parts(world_dir: Path, mission: Path, runs: Path, cpu_per_step: float) -> dict[str, float]:
    """µs per step of each part: cProfile self-time shares of one run, scaled to ``cpu_per_step``."""
    import vinecli.sim.runner as runner
    from vinecli.runs import RunRequest, run_mission

    prof = cProfile.Profile()
    fly = runner.fly  # profile the per-step loop only, not set-up and writing

    def profiled_fly(*a: Any, **kw: Any) -> Any:
        prof.enable()
        try:
            return fly(*a, **kw)
        finally:
            prof.disable()

    runner.fly = profiled_fly  # type: ignore[assignment]
    try:
        s = run_mission(RunRequest(mission, world_dir, runs, seed=0, run_id="profiled", overwrite=True))
    finally:
        runner.fly = fly
    steps = s.sim_time_s * 250.0
    stats = pstats.Stats(prof)
    totals: dict[str, float] = {}
    loop_total = 0.0
    for (filename, _line, func), (_cc, _nc, tt, _ct, _callers) in stats.stats.items():  # type: ignore[attr-defined]
        part = part_of(filename, func)
        totals[part] = totals.get(part, 0.0) + tt
        loop_total += tt
    # shares of the profiled loop, scaled to the loop's CPU per step measured without the profiler
    scale = cpu_per_step * steps / loop_total if loop_total > 0 else 0.0
    return {k: v * scale / steps for k, v in sorted(totals.items(), key=lambda kv: -kv[1])}


#: Python's default (bytecode cached in __pycache__): a PYTHONDONTWRITEBYTECODE=1 in the caller's environment
#: would make every new process compile each module it lacks a .pyc for
USER_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
#: the chosen third-party libraries every run imports
RUN_DEPENDENCIES = "numpy, pybullet, pydantic, typer, yaml, pyarrow.parquet"


def whole_process_rtf(world_dir: Path, mission: Path, runs: Path, tries: int = 3) -> tuple[float, float]:
    """(simulated s / wall s, wall s) of ``vinecli run mission`` as a new process, the best of ``tries``."""
    out = runs / f"cli-{mission.stem}"  # one directory per mission: its own summary.json
    walls = []
    for _ in range(tries):
        t = time.perf_counter()
        subprocess.run([sys.executable, "-m", "vinecli", "run", "mission", str(mission), "--world", str(world_dir),
                        "--out", str(out), "--seed", "0", "--overwrite"], check=False, capture_output=True, cwd=REPO,
                       env=USER_ENV)
        walls.append(time.perf_counter() - t)
    summaries = list(out.glob("*/summary.json"))
    if not summaries:
        return float("nan"), min(walls)
    return json.loads(summaries[0].read_text())["sim_time_s"] / min(walls), min(walls)


def dependencies_import_s(tries: int = 5) -> float:
    """Wall s of a bare interpreter importing :data:`RUN_DEPENDENCIES` (best of ``tries``)."""
    walls = []
    for _ in range(tries):
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", f"import {RUN_DEPENDENCIES}"], check=True, capture_output=True,
                       env=USER_ENV)
        walls.append(time.perf_counter() - t)
    return min(walls)


def terrain_load_s(world: Any) -> float:
    """Wall s to load the world's terrain into a new PyBullet engine (best of 3)."""
    from vinecli.world.engine import Engine

    walls = []
    for _ in range(3):
        with Engine(rate_hz=world.physics_rate_hz, gravity=world.gravity) as eng:
            t = time.perf_counter()
            eng.load_terrain(world.terrain)
            walls.append(time.perf_counter() - t)
    return min(walls)


def reference(world_dir: Path, mission: Path, runs: Path, parts: bool) -> dict[str, Any]:
    """The pure-Python reference in a subprocess: its loop's CPU µs per step (and its parts)."""
    env = {**os.environ, "VINECLI_PURE_PYTHON": "1"}
    out = subprocess.run([sys.executable, __file__, "--reference", str(world_dir), str(mission), str(runs)]
                         + (["--parts"] if parts else []), check=True, capture_output=True, text=True, env=env)
    return json.loads(out.stdout.splitlines()[-1])


def _reference_main(world_dir: Path, mission: Path, runs: Path, parts: bool) -> int:
    from vinecli import native
    from vinecli.runs import RunRequest, run_mission

    assert native.state == "pure", native.state
    s = run_mission(RunRequest(mission, world_dir, runs, seed=0, run_id="reference", overwrite=True))
    cpu = json.loads((Path(s.run_dir) / "summary.json").read_text())["timing"]["cpu_per_step_us"]
    row: dict[str, Any] = {"loop_cpu_us_per_step": cpu}
    if parts:
        row["parts_us_per_step"] = profile_parts(world_dir, mission, runs, cpu)
    print(json.dumps(row))
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--missions", nargs="+", default=["gust", "spray"], help="missions of pipelines/missions/")
    ap.add_argument("--parts", action="store_true", help="also profile each mission's reference loop by part")
    ap.add_argument("--json", type=Path, help="write the figures as JSON")
    ap.add_argument("--reference", nargs=3, type=Path, help=argparse.SUPPRESS)  # (internal) the subprocess
    args = ap.parse_args(argv)
    if args.reference:
        return _reference_main(*args.reference, args.parts)

    import numpy as np

    from vinecli import native
    from vinecli.runs import RunRequest, run_mission
    from vinecli.runs.rundir import TIMESERIES, read_timeseries
    from vinecli.world import build_world, load_world
    from vinecli.world.engine import reuse_terrain_engines

    res: dict[str, Any] = {"kernel": native.state, "missions": {}}
    print(f"kernel: {native.state}")
    with tempfile.TemporaryDirectory(prefix="vinecli-loop-") as tmp_s:
        tmp = Path(tmp_s)
        world_dir = build_world(REPO / "worlds" / "vineyard-sample.yaml", tmp / "world")
        world = load_world(world_dir)
        floor = floor_us(world, 5000)
        floor_ground = floor_us(world, 5000, on_ground=True)
        res["floor_cpu_us_per_step"] = floor
        res["floor_on_ground_cpu_us_per_step"] = floor_ground
        print(f"PyBullet floor (step + pose/velocity reads + 1 force + 1 torque), same world and body: "
              f"{floor:.1f} µs/step CPU in the air, {floor_ground:.1f} resting on the terrain (contacts solved)")
        deps_s, load_s = dependencies_import_s(), terrain_load_s(world)
        res.update(dependencies_import_s=deps_s, terrain_load_s=load_s)
        print(f"start-up no run can avoid: a bare interpreter importing {RUN_DEPENDENCIES} {deps_s:.2f} s wall, "
              f"loading the world's terrain into PyBullet {load_s:.2f} s")
        reuse_terrain_engines()  # as a batch worker: the second run of a mission is a warm case
        for name in args.missions:
            mission = REPO / "pipelines" / "missions" / f"{name}.yaml"
            s = run_mission(RunRequest(mission, world_dir, tmp / "runs", seed=0, run_id=name, overwrite=True))
            cpu = json.loads((Path(s.run_dir) / "summary.json").read_text())["timing"]["cpu_per_step_us"]
            ground = float(np.mean(read_timeseries(Path(s.run_dir) / TIMESERIES)["on_ground"] > 0.5))
            floor_run = (1.0 - ground) * floor + ground * floor_ground  # the floor of this run's mix of steps
            t = time.perf_counter()
            run_mission(RunRequest(mission, world_dir, tmp / "runs", seed=0, run_id=name, overwrite=True))
            warm = s.sim_time_s / (time.perf_counter() - t)
            rtf_proc, wall = whole_process_rtf(world_dir, mission, tmp / "runs")
            bound = s.sim_time_s / (deps_s + load_s + s.wall_time_s)  # vinecli's own start-up and writing free
            ref = reference(world_dir, mission, tmp / "runs", args.parts)
            ref_cpu = ref["loop_cpu_us_per_step"]
            row: dict[str, Any] = {"status": s.status, "sim_time_s": s.sim_time_s, "loop_cpu_us_per_step": cpu,
                                   "loop_over_floor": cpu / floor, "ground_share": ground,
                                   "loop_over_run_floor": cpu / floor_run, "loop_rtf_cpu": 4000.0 / cpu,
                                   "reference_cpu_us_per_step": ref_cpu, "kernel_speedup": ref_cpu / cpu,
                                   "warm_case_rtf": warm, "process_rtf": rtf_proc, "process_wall_s": wall,
                                   "process_rtf_startup_bound": bound}
            print(f"{name:8s} {s.sim_time_s:6.1f} s sim, {s.status}: loop {cpu:5.1f} µs/step CPU "
                  f"= {cpu / floor:4.1f}× floor (target <= 2.5; {ground:.0%} of the steps on the ground: "
                  f"{cpu / floor_run:3.1f}× that run's floor), {4000.0 / cpu:4.0f}× real time; pure-Python "
                  f"reference {ref_cpu:5.1f} µs/step ({ref_cpu / cpu:3.1f}× slower); whole case in a warm worker "
                  f"{warm:4.0f}×; whole `run mission` process {rtf_proc:4.0f}× ({wall:.2f} s wall; start-up bound "
                  f"{bound:4.0f}×)")
            if args.parts:
                row["reference_parts_us_per_step"] = ref["parts_us_per_step"]
                print("    parts of the pure-Python reference loop:")
                for part, us in ref["parts_us_per_step"].items():
                    print(f"    {part:28s} {us:6.1f} µs/step  ({us / ref_cpu * 100:4.1f} %)")
            res["missions"][name] = row
    if args.json:
        args.json.write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
