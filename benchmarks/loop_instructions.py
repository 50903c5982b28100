"""The loop's instructions and estimated cycles per step against the PyBullet floor's, counted by Valgrind: figures
a shared machine cannot move, to compare one checkout with another (e.g. before and after a change of the loop).

``loop_parts.py`` times the loop in CPU µs, which a virtual machine's neighbours inflate by 1.5-3x from one
minute to the next (its floor read 6.0 µs one day and 12-21 µs on an idle machine another, the same checkout's
loop / floor 2.5-7.1 within half an hour). Here Valgrind's callgrind counts what is executed instead, in two
processes per checkout and mission:

* **loop**: everything executed inside the compiled loop function (``vinecli.sim.loop.fly``, before the split
  ``vinecli.sim.runner._loop``) over one run of the mission (built-in autopilot, seed 0, the sample world), per
  250 Hz step, and the instructions inside PyBullet's calls;
* **floor**: PyBullet's own work per step of ``loop_parts.py``'s floor (``loop_parts.floor_us``:
  ``stepSimulation`` + pose and velocity reads + one force + one torque on the same world and body, floating,
  gravity off), 3 x 2000 steps.

Each is given in instructions and in estimated cycles from callgrind's simulated caches (iai-callgrind's
formula: L1 hits + 5 x last-level hits + 35 x memory accesses), so code that touches more memory shows. It
prints loop / floor for each mission of each checkout, and with ``--baseline`` this checkout's loop against the
baseline's in the same run. A model of a CPU, not a clock: it ranks code; a quiet ``loop_parts.py`` gives the
time. Needs ``valgrind`` and each checkout's compiled kernel (``make native``; a pure-Python kernel has no loop
symbol to count). ~15 min per checkout for gust and spray.

    .venv/bin/python benchmarks/loop_instructions.py [--missions gust spray] [--checkout DIR] [--baseline OTHER_CHECKOUT]
        [--json F]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
from loop_parts import FLOOR_REPEATS  # noqa: E402 - the floor this script counts is loop_parts.floor_us

#: the compiled loop, newest name first (mypyc: CPyDef_<module path with ___>___<function>)
LOOP_SYMBOLS = ("CPyDef_vinecli___sim___loop___fly", "CPyDef_vinecli___sim___runner____loop")
#: the floor's PyBullet calls (pybullet.c's C functions)
FLOOR_CALLS = ("stepSimulation", "getBasePositionAndOrientation", "getBaseVelocity", "applyExternalForce",
               "applyExternalTorque")
FLOOR_STEPS = 2000

#: run in the checkout (its path first on sys.path): the floor loop, or one mission run
CHILD = r"""
import json, sys
from pathlib import Path
sys.path.insert(0, sys.argv[1])

def floor(world_dir, steps):
    import importlib.util
    import vinecli  # the checkout's package first: loop_parts puts its own repository on sys.path
    from vinecli.world import load_world
    spec = importlib.util.spec_from_file_location("loop_parts", sys.argv[5])
    loop_parts = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(loop_parts)
    loop_parts.floor_us(load_world(world_dir), steps)

def mission(world_dir, mission_path, runs):
    from vinecli import native
    from vinecli.runs.mission import run_mission
    try:
        from vinecli.runs.request import RunRequest
    except ImportError:  # a checkout from before RunRequest: run_mission's keywords
        s = run_mission(mission_path, world_dir, runs, seed=0, run_id="counted", overwrite=True)
    else:
        s = run_mission(RunRequest(mission_path, world_dir, runs, seed=0, run_id="counted", overwrite=True))
    print(json.dumps({"kernel": native.state, "status": s.status, "sim_time_s": s.sim_time_s}))

if __name__ == "__main__":
    if sys.argv[2] == "floor":
        floor(Path(sys.argv[3]), int(sys.argv[4]))  # loop_parts.floor_us: FLOOR_REPEATS x steps
    else:
        mission(Path(sys.argv[3]), Path(sys.argv[4]), Path(sys.argv[5]))
"""


def loop_symbol(checkout: Path) -> str:
    """The compiled loop's symbol in ``checkout``'s kernel (``nm`` of its extension modules)."""
    for so in sorted((checkout / "vinecli" / "sim").glob("*__mypyc*.so")):
        names = subprocess.run(["nm", str(so)], check=True, capture_output=True, text=True).stdout
        for sym in LOOP_SYMBOLS:
            if re.search(rf" T {sym}$", names, re.MULTILINE):
                return sym
    raise SystemExit(f"{checkout}: no compiled loop (run `make native` there)")


def callgrind(args: list[str], toggles: list[str], out: Path) -> str:
    """Run ``python args`` under callgrind (cache simulation on) collecting only inside ``toggles``; its stdout."""
    cmd = ["valgrind", "--tool=callgrind", "--cache-sim=yes", "--collect-atstart=no", f"--callgrind-out-file={out}",
           *[f"--toggle-collect={t}" for t in toggles], sys.executable, *args]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    res = subprocess.run(cmd, check=False, capture_output=True, text=True, env=env)
    if res.returncode != 0:
        raise SystemExit(f"valgrind {' '.join(args[:3])}: exit {res.returncode}\n{res.stderr[-2000:]}")
    return res.stdout


def counts(out: Path) -> dict[str, float]:
    """Instructions (``Ir``) and estimated cycles collected in one callgrind output file. Estimated cycles as
    iai-callgrind counts them from the simulated caches: L1 hits + 5 x last-level hits + 35 x memory accesses."""
    text = out.read_text()
    ev = re.search(r"^events: (.+)$", text, re.MULTILINE)
    tot = re.search(r"^totals: (.+)$", text, re.MULTILINE)
    if ev is None or tot is None:
        raise SystemExit(f"{out}: no events/totals line")
    c = dict(zip(ev.group(1).split(), (float(v) for v in tot.group(1).split()), strict=True))
    accesses = c["Ir"] + c["Dr"] + c["Dw"]
    l1_miss = c["I1mr"] + c["D1mr"] + c["D1mw"]
    ram = c["ILmr"] + c["DLmr"] + c["DLmw"]
    return {"instructions": c["Ir"], "cycles": (accesses - l1_miss) + 5.0 * (l1_miss - ram) + 35.0 * ram}


def pybullet_inclusive(out: Path) -> float:
    """Instructions inside PyBullet's Python-facing C functions (``pybullet_*``, inclusive), from callgrind."""
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--show=Ir", "--threshold=100", str(out)],
                          check=True, capture_output=True, text=True).stdout
    total = 0.0
    for line in text.splitlines():
        m = re.match(r"\s*([\d,]+)\s+\([^)]*\)\s+\S*:pybullet_(\w+)\b", line)
        if m:
            total += int(m.group(1).replace(",", ""))
    return total


def measure(checkout: Path, missions: list[str], tmp: Path) -> dict[str, Any]:
    """Floor and loop instructions per step of ``checkout`` (its own world build of the sample)."""
    child = tmp / "child.py"
    child.write_text(CHILD)
    world = tmp / f"world-{checkout.name}"
    subprocess.run([sys.executable, "-c", f"import sys; sys.path.insert(0, {str(checkout)!r}); "
                    "from pathlib import Path; from vinecli.world import build_world; "
                    f"build_world(Path({str(checkout / 'worlds' / 'vineyard-sample.yaml')!r}), Path({str(world)!r}))"],
                   check=True, capture_output=True)
    sym = loop_symbol(checkout)
    fout = tmp / f"floor-{checkout.name}.out"
    callgrind([str(child), str(checkout), "floor", str(world), str(FLOOR_STEPS),
               str(REPO / "benchmarks" / "loop_parts.py")], [f"pybullet_{c}" for c in FLOOR_CALLS], fout)
    floor = {k: v / (FLOOR_REPEATS * FLOOR_STEPS) for k, v in counts(fout).items()}
    res: dict[str, Any] = {"checkout": str(checkout), "loop_symbol": sym, "floor_per_step": floor, "missions": {}}
    print(f"{checkout}: floor {floor['instructions']:,.0f} instructions = {floor['cycles']:,.0f} estimated cycles "
          f"per step (PyBullet's own, {FLOOR_REPEATS} x {FLOOR_STEPS} steps)", flush=True)
    for name in missions:
        mout = tmp / f"loop-{checkout.name}-{name}.out"
        stdout = callgrind([str(child), str(checkout), "mission", str(world),
                            str(checkout / "pipelines" / "missions" / f"{name}.yaml"), str(tmp / "runs")], [sym], mout)
        run = json.loads(stdout.strip().splitlines()[-1])
        if run["kernel"] != "compiled":
            raise SystemExit(f"{checkout}: the kernel ran {run['kernel']}, not compiled (make native there)")
        steps = run["sim_time_s"] * 250.0
        loop = {k: v / steps for k, v in counts(mout).items()}
        pyb = pybullet_inclusive(mout) / steps
        row = {"status": run["status"], "sim_time_s": run["sim_time_s"], "loop_per_step": loop,
               "pybullet_instructions_per_step": pyb,
               "loop_over_floor": {k: loop[k] / floor[k] for k in loop}}
        res["missions"][name] = row
        print(f"  {name:8s} {run['sim_time_s']:6.1f} s sim, {run['status']}: loop {loop['instructions']:,.0f} "
              f"instructions/step = {row['loop_over_floor']['instructions']:.2f}x floor, estimated cycles "
              f"{row['loop_over_floor']['cycles']:.2f}x floor (instructions inside PyBullet's calls {pyb:,.0f}, "
              f"vinecli's own {loop['instructions'] - pyb:,.0f})", flush=True)
    return res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--missions", nargs="+", default=["gust", "spray"], help="missions of pipelines/missions/")
    ap.add_argument("--checkout", type=Path, default=REPO, help="the checkout to measure (default: this one)")
    ap.add_argument("--baseline", type=Path, help="another checkout (its kernel built) to compare with")
    ap.add_argument("--json", type=Path, help="write the figures as JSON")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="vinecli-instr-") as tmp_s:
        tmp = Path(tmp_s)
        res: dict[str, Any] = {"this": measure(args.checkout.resolve(), args.missions, tmp)}
        if args.baseline is not None:
            res["baseline"] = base = measure(args.baseline.resolve(), args.missions, tmp)
            for name in args.missions:
                a, b = res["this"]["missions"][name], base["missions"][name]
                own = [m["loop_per_step"]["instructions"] - m["pybullet_instructions_per_step"] for m in (a, b)]
                print(f"{name}: this / baseline: loop instructions "
                      f"{a['loop_per_step']['instructions'] / b['loop_per_step']['instructions']:.2f}x, estimated "
                      f"cycles {a['loop_per_step']['cycles'] / b['loop_per_step']['cycles']:.2f}x; loop / floor "
                      f"{a['loop_over_floor']['cycles']:.2f} vs {b['loop_over_floor']['cycles']:.2f} (cycles); "
                      f"vinecli's own instructions {own[0] / own[1]:.2f}x")
    if args.json:
        args.json.write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
