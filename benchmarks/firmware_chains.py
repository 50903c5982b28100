"""The two real-firmware test chains (tests/xdist_scopes.py: one xdist worker runs each firmware's tests one after
the other) of this checkout against a baseline checkout, interleaved, one chain at a time on one pytest worker:
wall time per chain and round, the load average at its start and end, the ratios (this / baseline), and with
``--phases`` where each test's time went (benchmarks/firmware_phases.py).

    .venv/bin/python benchmarks/firmware_chains.py --baseline /work/main [--rounds 2] [--chains ardupilot px4]
        [--phases] [--out DIR]

The baseline runs from its own checkout with its own ``.venv`` (nothing written there: no byte code, no pytest
cache). Needs ../shared's PX4 and ArduPilot (else the chains skip).
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CHAINS = {"ardupilot": "real firmware: ArduPilot", "px4": "real firmware: PX4"}


def chain_ids(checkout: Path, chain: str) -> list[str]:
    """The node ids of ``chain`` in ``checkout`` (collected there, scoped by its tests/xdist_scopes.py)."""
    code = ("import sys; from pathlib import Path; sys.path.insert(0, 'tests'); from xdist_scopes import scope_of\n"
            "for line in sys.stdin:\n"
            "    n = line.strip()\n"
            f"    if '::' in n and scope_of(Path.cwd(), n) == {CHAINS[chain]!r}: print(n)\n")
    python = str(checkout / ".venv" / "bin" / "python")
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    ids = subprocess.run([python, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
                          "tests"], cwd=checkout, env=env, capture_output=True, text=True).stdout
    return subprocess.run([python, "-c", code], cwd=checkout, env=env, input=ids, capture_output=True,
                          text=True, check=True).stdout.split()


def run_chain(checkout: Path, ids: list[str], log: Path, phases: Path | None) -> tuple[float, str, str]:
    """(wall s, pytest's summary line, load averages at start -> end) of one chain run."""
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    plugin: list[str] = []
    if phases is not None:
        site = Path(tempfile.mkdtemp(prefix="fwphases-"))
        (site / "sitecustomize.py").write_text("import firmware_phases\nfirmware_phases.install()\n")
        env.update(FWPHASE_LOG=str(phases), PYTHONPATH=os.pathsep.join([str(site), str(REPO / "benchmarks")]))
        plugin = ["-p", "firmware_phases"]
    load0 = os.getloadavg()[0]
    t0 = time.monotonic()
    with log.open("w") as out:
        subprocess.run(["nice", "-n", "5", str(checkout / ".venv" / "bin" / "python"), "-m", "pytest", "-p", "no:xdist",
                        "-p", "no:cacheprovider", *plugin, "-q", "-rfE", "--durations=0", *ids],
                       cwd=checkout, env=env, stdout=out, stderr=subprocess.STDOUT)
    wall = time.monotonic() - t0
    found = re.findall(r"^=* ?(\d+ (?:passed|failed|error).*) in [0-9.]+s", log.read_text(), re.MULTILINE)
    return wall, found[-1] if found else "no summary", f"{load0:.1f} -> {os.getloadavg()[0]:.1f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", type=Path, required=True, help="a checkout with its own .venv (e.g. main)")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--chains", nargs="+", choices=list(CHAINS), default=list(CHAINS))
    ap.add_argument("--phases", action="store_true", help="time each firmware run's phases")
    ap.add_argument("--out", type=Path, default=None, help="keep the logs here (default: a temporary folder)")
    a = ap.parse_args()
    out = a.out or Path(tempfile.mkdtemp(prefix="firmware-chains-"))
    out.mkdir(parents=True, exist_ok=True)
    sides = {"this": REPO, "baseline": a.baseline.resolve()}
    walls: dict[tuple[str, str], list[float]] = {}
    for r in range(a.rounds):
        for chain in a.chains:
            order = ("this", "baseline") if (r + a.chains.index(chain)) % 2 == 0 else ("baseline", "this")
            for side in order:
                ids = chain_ids(sides[side], chain)
                tag = f"{side}-{chain}-{r}"
                phases = out / f"{tag}.phases.jsonl" if a.phases else None
                wall, summary, load = run_chain(sides[side], ids, out / f"{tag}.log", phases)
                walls.setdefault((side, chain), []).append(wall)
                print(f"round {r} {chain:9s} {side:8s} {len(ids):2d} tests  {wall:7.1f} s  load {load}  {summary}",
                      flush=True)
    for chain in a.chains:
        this, base = walls[("this", chain)], walls[("baseline", chain)]
        ratios = [t / b for t, b in zip(this, base, strict=True)]
        print(f"{chain:9s} this {statistics.median(this):7.1f} s  baseline {statistics.median(base):7.1f} s  "
              f"ratio per round {', '.join(f'{x:.2f}' for x in ratios)} (median {statistics.median(ratios):.2f})")
    if a.phases:
        sys.path.insert(0, str(REPO / "benchmarks"))
        from firmware_phases import breakdown

        for log in sorted(out.glob("*.phases.jsonl")):
            print(f"\n## {log.name}")
            print({k: round(v, 1) for k, v in breakdown(log).items()})
    print(f"\nlogs: {out}")


if __name__ == "__main__":
    main()
