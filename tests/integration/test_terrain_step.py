"""Terrain following over a 3 m step (a building/tree edge in a DSM) through the real loop:
spraying 2 m above the terrain, the built-in autopilot climbs before the step (look-ahead) and
keeps >= 1 m between the airframe's footprint and the terrain."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import rasterio
import yaml
from rasterio.transform import from_origin

from vinecli.autopilot.registry import make_autopilot
from vinecli.sim.runner import run_simulation
from vinecli.specs.mission import MissionSpec
from vinecli.world import build_world, load_world


def test_spray_over_a_3m_step_keeps_1m_clearance(tmp_path: Path) -> None:
    n = 257  # 0.2 m pixels, 51.2 m square; the northern half is 3 m higher (edge at y = 0)
    y_north = (np.arange(n) * 0.2)[:, None] * np.ones((1, n))
    z = (400.0 + 3.0 * (y_north < 25.6)).astype(np.float32)
    tif = tmp_path / "step.tif"
    with rasterio.open(tif, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32632",
                       transform=from_origin(465000.0, 5250000.0, 0.2, 0.2)) as ds:
        ds.write(z, 1)
    spec = tmp_path / "world.yaml"
    spec.write_text(yaml.safe_dump({
        "name": "step", "vehicle": "x500-sprayer", "spawn": {"x_m": 0.0, "y_m": -20.0},
        "terrain": {"type": "dsm", "path": str(tif), "format": "heightmap", "size": 257},
        "rows": [[[0.0, -15.0], [0.0, 15.0]]],
    }))
    w = load_world(build_world(spec, tmp_path / "w"))
    assert w.terrain_height(0.0, -5.0) == 0.0 and abs(w.terrain_height(0.0, 5.0) - 3.0) < 1e-3
    m = MissionSpec(name="step", max_duration_s=60.0, tank_fill_l=1.0, record_rate_hz=50.0, phases=[
        {"type": "takeoff", "altitude_agl_m": 2.0},
        {"type": "spray", "rows": "world", "height_agl_m": 2.0, "speed_mps": 2.0, "flow_lps": 0.01},
        {"type": "land"}])
    ap = make_autopilot("builtin")
    try:
        r = run_simulation(w, m, ap, seed=1)
    finally:
        ap.close()
    assert r.status.value == "completed", r.detail
    ts = r.timeseries
    sel = ts["phase_index"] == 1
    lgh = w.vehicle.frame.landing_gear_height_m
    half = 0.5 * w.vehicle.frame.collision_box_m[0]
    x, y, zc = ts["pos_enu_x_m"][sel], ts["pos_enu_y_m"][sel], ts["pos_enu_z_m"][sel]
    offs = [(-half, -half), (-half, half), (half, -half), (half, half), (0.0, 0.0)]
    ground = np.max([w.terrain.grid.heights(x + dx, y + dy) for dx, dy in offs], axis=0)
    clearance = zc - lgh - ground  # skids above the highest terrain under the airframe
    assert clearance.min() >= 1.0, clearance.min()
    assert y.max() > 10.0  # flew over the step, at the set height above the upper level
    upper = sel & (ts["pos_enu_y_m"] > 5.0) & (ts["pos_enu_y_m"] < 12.0)
    assert abs(np.mean(ts["height_agl_m"][upper]) - 2.0) < 0.3
    assert not [e for e in r.events if e.kind in ("crash",)]
