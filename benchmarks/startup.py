"""Start-up: what each command costs before its work, and whole `run mission` processes, against another checkout
in the same run.

For this checkout and, with ``--baseline DIR``, another one (each with its own build of the sample world; the
same Python environment, the checkout first on ``sys.path``), interleaved round by round, best of ``--rounds``
(the machine's neighbours move single timings by 2x; the best of interleaved rounds compares like with like):

* **imports** of each command: ``python -X importtime -m vinecli <command>``, the sum of its top-level imports
  (what the command imported, in the order it did, including the imports inside its function bodies), and the
  whole process's wall time: ``vinecli --help``, ``vinecli vehicle fit --help``, ``vinecli run mission --help``
  and ``vinecli run mission`` of each mission;
* **whole process** per mission: ``vinecli run mission`` of the CI missions (takeoff, gust, overload, spray),
  wall s, and simulated s / wall s;
* **terrain load**: the sample world's terrain into a new PyBullet engine (each checkout's own ``load_terrain``);
* with ``--count``, the same in instructions, counted by Valgrind (callgrind), which a loaded machine cannot move:
  the help commands' whole processes, each mission's imports (a fresh interpreter importing, in order, the
  top-level modules the mission's process imported) and the terrain load (a process loading it, less one that
  stops before).

Bytecode is cached as Python does by default (a ``PYTHONDONTWRITEBYTECODE`` of the caller's environment is
dropped; one warm-up round writes the caches). Ratios this / baseline < 1 are faster.

    .venv/bin/python benchmarks/startup.py [--baseline OTHER_CHECKOUT] [--rounds 5] [--missions takeoff gust]
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
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
MISSIONS = ("takeoff", "gust", "overload", "spray")
HELP_COMMANDS: dict[str, list[str]] = {
    "vinecli --help": ["--help"],
    "vinecli vehicle fit --help": ["vehicle", "fit", "--help"],
    "vinecli run mission --help": ["run", "mission", "--help"],
}
_IMPORT_LINE = re.compile(r"import time:\s+\d+ \|\s+(\d+) \| (\S.*)$")

TERRAIN_LOAD = r"""
import sys, time
from pathlib import Path
sys.path.insert(0, sys.argv[1])
from vinecli.world import load_world
from vinecli.world.engine import Engine
w = load_world(Path(sys.argv[2]))
best = 1e9
for _ in range(int(sys.argv[3])):
    with Engine(rate_hz=w.physics_rate_hz, gravity=w.gravity) as e:
        t = time.perf_counter()
        e.load_terrain(w.terrain)
        best = min(best, time.perf_counter() - t)
print(best)
"""


def instructions(args: list[str], checkout: Path) -> float:
    """Instructions executed by ``python args`` in ``checkout`` (callgrind, the whole process)."""
    res = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", sys.executable, *args],
                         cwd=checkout, env=_env(checkout), capture_output=True, text=True)
    m = re.search(r"Collected : (\d+)", res.stderr)
    if m is None:
        raise SystemExit(f"valgrind {' '.join(args[:3])}: {res.stderr[-1000:]}")
    return float(m.group(1))


def imported_modules(checkout: Path, args: list[str]) -> list[str]:
    """The top-level modules ``vinecli args`` imports, in order (``-X importtime``)."""
    res = subprocess.run([sys.executable, "-X", "importtime", "-m", "vinecli", *args], cwd=checkout,
                         env=_env(checkout), capture_output=True, text=True)
    return [m.group(2).strip() for line in res.stderr.splitlines()
            if (m := _IMPORT_LINE.match(line)) and not m.group(2).startswith(" ")]


def counts(checkout: Path, cmds: dict[str, list[str]], world: Path) -> dict[str, float]:
    """Instructions (see the module doc) per help command, per mission's imports, and of the terrain load."""
    out: dict[str, float] = {}
    for name, args in cmds.items():
        if name.startswith("run mission "):
            mods = [m for m in imported_modules(checkout, args) if m != "__main__"]
            out[f"{name} (imports)"] = instructions(["-c", "import " + ", ".join(mods)], checkout)
        else:
            out[name] = instructions(["-m", "vinecli", *args], checkout)
    load = instructions(["-c", TERRAIN_LOAD, str(checkout), str(world), "1"], checkout)
    out["terrain load"] = load - instructions(["-c", TERRAIN_LOAD, str(checkout), str(world), "0"], checkout)
    return out


def _env(checkout: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(checkout)
    return env


def run_command(checkout: Path, args: list[str]) -> tuple[float, float, int]:
    """(wall s of the whole process, s of its top-level imports, exit code) of ``python -X importtime -m vinecli
    args`` in ``checkout``."""
    t = time.perf_counter()
    res = subprocess.run([sys.executable, "-X", "importtime", "-m", "vinecli", *args], cwd=checkout,
                         env=_env(checkout), capture_output=True, text=True)
    wall = time.perf_counter() - t
    imports = sum(int(m.group(1)) for line in res.stderr.splitlines() if (m := _IMPORT_LINE.match(line))) * 1e-6
    return wall, imports, res.returncode


def build_world(checkout: Path, out: Path) -> Path:
    """The sample world built by ``checkout``'s own code."""
    if not (out / "world.json").is_file():
        subprocess.run([sys.executable, "-m", "vinecli", "world", "build", str(checkout / "worlds" / "vineyard-sample.yaml"),
                        "--out", str(out)], cwd=checkout, env=_env(checkout), check=True, capture_output=True)
    return out


def commands(checkout: Path, world: Path, runs: Path, missions: list[str]) -> dict[str, list[str]]:
    cmds = dict(HELP_COMMANDS)
    for m in missions:
        cmds[f"run mission {m}"] = ["run", "mission", str(checkout / "pipelines" / "missions" / f"{m}.yaml"), "--world",
                                    str(world), "--out", str(runs), "--seed", "0", "--overwrite"]
    return cmds


def sim_time(runs: Path, mission: str) -> float:
    return float(json.loads((runs / f"{mission}-s0" / "summary.json").read_text())["sim_time_s"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", type=Path, help="another checkout to compare with (same Python environment)")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds (best of)")
    ap.add_argument("--missions", nargs="+", default=list(MISSIONS), help="missions of pipelines/missions/")
    ap.add_argument("--count", action="store_true", help="also count instructions with Valgrind (slow)")
    ap.add_argument("--json", type=Path, help="write the figures as JSON")
    args = ap.parse_args(argv)
    checkouts = {"this": REPO}
    if args.baseline is not None:
        checkouts["baseline"] = args.baseline.resolve()
    res: dict[str, Any] = {"checkouts": {k: str(v) for k, v in checkouts.items()}, "rounds": args.rounds}
    with tempfile.TemporaryDirectory(prefix="vinecli-startup-") as tmp_s:
        tmp = Path(tmp_s)
        worlds = {k: build_world(c, tmp / f"world-{k}") for k, c in checkouts.items()}
        cmds = {k: commands(c, worlds[k], tmp / f"runs-{k}", args.missions) for k, c in checkouts.items()}
        best: dict[str, dict[str, list[float]]] = {k: {} for k in checkouts}
        for rnd in range(args.rounds + 1):  # round 0 writes the bytecode caches and is not counted
            for name in cmds["this"]:
                for k, c in checkouts.items():
                    wall, imports, rc = run_command(c, cmds[k][name])
                    if rc not in (0, 1):  # 1: a run whose checks failed is still a run
                        raise SystemExit(f"{k}: vinecli {' '.join(cmds[k][name])} exited {rc}")
                    if rnd:
                        old = best[k].get(name, [float("inf"), float("inf")])
                        best[k][name] = [min(old[0], wall), min(old[1], imports)]
        loads = {k: min(float(subprocess.run([sys.executable, "-c", TERRAIN_LOAD, str(c), str(worlds[k]), "3"],
                                                 env=_env(c), capture_output=True, text=True, check=True).stdout)
                            for _ in range(args.rounds)) for k, c in checkouts.items()}
        sims = {m: sim_time(tmp / "runs-this", m) for m in args.missions}
        counted = {k: counts(c, cmds[k], worlds[k]) for k, c in checkouts.items()} if args.count else {}
    res["commands"] = {}
    print(f"best of {args.rounds} interleaved rounds; wall s of the whole process, s of its imports"
          + (" (this / baseline)" if "baseline" in checkouts else ""))
    for name in cmds["this"]:
        row: dict[str, Any] = {k: {"wall_s": best[k][name][0], "imports_s": best[k][name][1]} for k in checkouts}
        mission = name.removeprefix("run mission ") if name.startswith("run mission ") else None
        line = f"{name:30s} wall {best['this'][name][0]:6.3f} s, imports {best['this'][name][1]:6.3f} s"
        if mission is not None:
            row["sim_time_s"] = sims[mission]
            row["real_time_factor"] = sims[mission] / best["this"][name][0]
            line += f", {row['real_time_factor']:5.1f}x real time ({sims[mission]:.1f} s simulated)"
        if "baseline" in checkouts:
            b = best["baseline"][name]
            row["ratio_wall"] = best["this"][name][0] / b[0]
            row["ratio_imports"] = best["this"][name][1] / b[1]
            line += f"  | baseline wall {b[0]:6.3f}, imports {b[1]:6.3f}: {row['ratio_wall']:.2f}x, {row['ratio_imports']:.2f}x"
        print(line)
        res["commands"][name] = row
    res["terrain_load_s"] = loads
    line = f"{'sample terrain into PyBullet':30s} {loads['this']:6.3f} s"
    if "baseline" in checkouts:
        line += f"  | baseline {loads['baseline']:6.3f} s: {loads['this'] / loads['baseline']:.2f}x"
    print(line)
    if counted:
        res["instructions"] = counted
        print("instructions (callgrind)" + (": this / baseline" if "baseline" in checkouts else ""))
        for name, n in counted["this"].items():
            line = f"{name:40s} {n / 1e6:9.1f} M"
            if "baseline" in checkouts:
                line += f"  | baseline {counted['baseline'][name] / 1e6:9.1f} M: {n / counted['baseline'][name]:.2f}x"
            print(line)
    if args.json:
        args.json.write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
