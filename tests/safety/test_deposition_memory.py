"""Bounded memory. A spray height of 400 m built an 8.2 GB deposition grid (the disc kernel
of a ~340 m footprint at 0.1 m cells); now the grid keeps its padded convolution inside a cell budget
(coarser cells), so the peak stays far below 1.5 GB at any height, and the volume balance still holds.
Drag and the rotor wake keep a drop's footprint to a few metres even from 400 m (the
cones' 340 m footprint is ``DepositionConfig(drag_reach=False)``, still exercised here), and the far field's
parcels are bounded (spray/deposition.py MAX_FAR_PARCELS).

Each case runs in a child process under an address-space ceiling (tests/safety/memguard.py), so the
unbounded allocation of the old code fails there with MemoryError instead of exhausting the machine.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from memguard import run_child, run_python

LIMIT_MB = 1536.0

DEPOSIT_AT = """
import json, sys
import numpy as np
from vinecli.spray.deposition import EMIT_COLUMNS, SprayEmitter
from vinecli.sim.spray_deposit import deposit
from vinecli.world import load_world
h = float(sys.argv[1])
world = load_world(sys.argv[2])
em = SprayEmitter()
for i in range(250):  # 10 s along +x at 2 m/s, 0.02 L/s, one record per 0.04 s
    t = 0.04 * i
    em.emit((t, 2.0 * t - 10.0, 0.0, h, 0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 30.0, 0.0008, 0.0))
from vinecli.spray.deposition import DepositionConfig
dep = deposit(em, world, world.vehicle, world.wind, seed=1, config=DepositionConfig(drag_reach=CONE))
print(json.dumps({"cell": dep.grid.cell, "nx": dep.grid.nx, "ny": dep.grid.ny, "emitted": dep.emitted_l,
                  "balance": dep.balance_error, "on_grid": dep.on_grid_l}))
"""


@pytest.mark.parametrize(("height", "drag"), [(2.0, True), (400.0, True), (400.0, False)])
def test_deposition_grid_stays_in_budget_at_any_height(flat_world_dir: Path, height: float, drag: bool) -> None:
    r = run_python(DEPOSIT_AT.replace("sys.argv[1]", repr(str(height))).replace("sys.argv[2]", repr(str(flat_world_dir)))
                   .replace("CONE", repr(drag)))
    assert r.returncode == 0, r.stderr[-2000:]
    d = json.loads(r.stdout.strip().splitlines()[-1])
    assert d["balance"] < 1e-9  # emitted = on grid + off grid, whatever the cell
    assert r.peak_rss_mb < 800.0, f"peak {r.peak_rss_mb:.0f} MB at {height} m"
    if drag:
        assert d["cell"] == pytest.approx(0.1)  # drag and the wake keep the footprint to metres: 0.1 m cells
    else:
        assert d["cell"] > 0.1  # coarser cells carry the cones' 340 m footprint


MISSION = """\
name: high
vehicle: x500-sprayer
tank_fill_l: 0.3
max_duration_s: 200
record_rate_hz: 2
geofence: {polygon_enu: [[-90, -90], [90, -90], [90, 90], [-90, 90]], max_altitude_agl_m: 1000}
phases:
  - {type: takeoff, altitude_agl_m: 400, timeout_s: 400}
  - {type: spray, rows: [[[0.0, 0.0], [10.0, 0.0]]], height_agl_m: 400, speed_mps: 3.0, flow_lps: 0.02}
  - {type: land}
"""


def test_spraying_at_400_m_completes_under_1_5_gb(flat_world_dir: Path, tmp_path: Path) -> None:
    (tmp_path / "high.yaml").write_text(MISSION)
    exe = str(Path(sys.executable).with_name("vinecli"))
    r = run_child([exe, "run", "mission", "high.yaml", "--world", str(flat_world_dir), "--out", "runs"], cwd=tmp_path)
    assert r.returncode in (0, 1), r.stderr[-2000:]  # it flew (its checks decide 0 or 1), no exit 3
    assert r.peak_rss_mb < LIMIT_MB, f"peak {r.peak_rss_mb:.0f} MB"
    dep = json.loads((tmp_path / "runs" / "high-s0" / "deposition.json").read_text())
    assert dep["totals"]["balance_error"] < 1e-9


LONG = """\
name: long
vehicle: x500-sprayer
max_duration_s: 86400
record_rate_hz: 50
phases:
  - {type: takeoff, altitude_agl_m: 1.0}
  - {type: land}
"""


def test_a_mission_that_cannot_fit_is_refused_at_load(flat_world_dir: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from vinecli.cli.app import app

    (tmp_path / "long.yaml").write_text(LONG)
    r = CliRunner().invoke(app, ["run", "mission", str(tmp_path / "long.yaml"), "--world", str(flat_world_dir),
                                 "--out", str(tmp_path / "runs")])
    assert r.exit_code == 2, r.output
    line = " ".join(r.stderr.split())
    assert "86400" in line and "GB" in line and "record_rate_hz" in line  # the numbers, and what to change
    assert not (tmp_path / "runs" / "long-s0").exists()
    (tmp_path / "p.yaml").write_text(f"name: p\nworld: {flat_world_dir}\nmissions: [long.yaml]\n")
    r = CliRunner().invoke(app, ["run", "batch", str(tmp_path / "p.yaml"), "--out", str(tmp_path / "b")])
    assert r.exit_code == 2, r.output
    assert "case long" in r.stderr and not (tmp_path / "b" / "long").exists()


CANOPY_WORLD = """\
name: canopy-flat
terrain: {type: flat, z_m: 0.0, size_m: 400.0}
origin: {lat: 44.7, lon: 8.03, alt: 250.0}
vehicle: x500-sprayer
rows: [ROWS]
canopy: {bbch: 75}
""".replace("ROWS", ", ".join(f"[[-40, {y}], [40, {y}]]" for y in (-10.0, -7.5, -5.0, -2.5, 0.0, 2.5, 5.0, 7.5, 10.0)))

BUDGET_AT = """
import json, tracemalloc
from pathlib import Path
from vinecli.spray.deposition import SprayEmitter, SprayerGeometry
from vinecli.runs.budget_out import evaluate_budget, write_budget
from vinecli.sim.spray_deposit import deposit
from vinecli.sim.memory import _budget_mb
from vinecli.world import load_world
h, n, out = HEIGHT, RECORDS, OUT
world = load_world(WORLD)
em = SprayEmitter()
for i in range(n):  # along the rows at 2 m/s, one record per 0.04 s
    x = (0.08 * i) % 160 - 80
    em.emit((0.04 * i, x, -10 + 2.5 * (int(0.08 * i // 160) % 9), h, 0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0,
             0.0, 30.0, 0.0008, 0.0))
dep = deposit(em, world, world.vehicle, world.wind, seed=1)
geo = SprayerGeometry.from_vehicle(world.vehicle, world.air_density)
primary = n * len(world.vehicle.sprayer.nozzles) * world.vehicle.sprayer.droplets.classes
bound = _budget_mb(world, dep.grid, primary, n, float(dep.parcels.radius.max()))
tracemalloc.start()
b = evaluate_budget(dep, world, world.vine_rows_enu, 200.0)
write_budget(Path(out), b, dep, world, None)
peak = tracemalloc.get_traced_memory()[1] / 1e6
print(json.dumps({"peak_mb": peak, "bound_mb": bound, "balance": b.budget.balance_error}))
"""


@pytest.fixture(scope="module")
def canopy_world_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """CANOPY_WORLD, built once for the module."""
    from vinecli.world import build_world

    d = tmp_path_factory.mktemp("canopy")
    (d / "w.yaml").write_text(CANOPY_WORLD)
    return build_world(d / "w.yaml", d / "w")


@pytest.mark.parametrize("height", [2.0, 400.0])
def test_the_spray_budget_stays_within_its_share_of_the_memory_estimate(canopy_world_dir: Path, tmp_path: Path,
                                                                          height: float) -> None:
    """sim/memory.py counts the budget (its per-parcel arrays, the canopy points of every hedge a footprint reaches,
    the canopy maps): what evaluating and writing it allocates (tracemalloc, imports included) stays below."""
    world = canopy_world_dir
    code = (BUDGET_AT.replace("HEIGHT", repr(height)).replace("RECORDS", "2500").replace("OUT", repr(str(tmp_path)))
            .replace("WORLD", repr(str(world))))
    r = run_python(code)
    assert r.returncode == 0, r.stderr[-2000:]
    d = json.loads(r.stdout.strip().splitlines()[-1])
    assert d["balance"] < 1e-9
    assert d["peak_mb"] < d["bound_mb"], d
