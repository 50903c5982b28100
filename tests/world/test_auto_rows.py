"""``rows: auto`` worlds: rows detected at ``world build`` (on the source DSM), the same rows in ``plan rows``
(on the DSM and on the world) and in the run, sprayed in the real loop."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import rasterio
import yaml
from rasterio.transform import from_origin

from vinecli.runs import RunRequest, run_mission


def vineyard_tif(path: Path) -> None:
    """40 m x 40 m, 0.1 m pixels, UTM 32N; rows along 20 deg (ENU grid), 2.5 m apart, 1 m canopy."""
    res, n = 0.1, 401
    xs = (np.arange(n) + 0.5) * res - 20.0
    ys = 20.0 - (np.arange(n) + 0.5) * res
    X, Y = np.meshgrid(xs, ys)
    th = math.radians(20.0)
    s = -math.sin(th) * X + math.cos(th) * Y
    z = 240.0 + 1.0 * np.clip(np.cos(2 * np.pi * s / 2.5), 0, None) ** 2
    with rasterio.open(path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32632",
                       transform=from_origin(424000.0, 4950040.0, res, res)) as ds:
        ds.write(z.astype("float32"), 1)


def test_auto_rows_are_detected_and_sprayed(tmp_path: Path) -> None:
    from vinecli.world import build_world

    vineyard_tif(tmp_path / "v.tif")
    (tmp_path / "w.yaml").write_text(yaml.safe_dump({
        "name": "auto-rows", "terrain": {"type": "dsm", "path": "v.tif", "format": "heightmap", "size": 257},
        "vehicle": "x500-sprayer", "spawn": {"x_m": 0.0, "y_m": 1.33}, "rows": "auto",  # in a furrow
    }))
    world = build_world(tmp_path / "w.yaml", tmp_path / "world")
    wj = json.loads((world / "world.json").read_text())
    assert wj["rows_auto"] and len(wj["vine_rows_enu"]) == wj["rows_detection"]["count"] >= 14
    assert wj["rows_detection"]["source"] == "dsm" and wj["rows_detection"]["confidence"] >= 0.8
    assert abs(wj["rows_detection"]["direction_deg"] - 20.0) < 0.5
    # plan rows on the DSM and on the world: the same rows (rows.rows.geojson, WGS84 through the DSM's CRS)
    from typer.testing import CliRunner

    from vinecli.cli.app import app

    for name, src in (("plan-dsm", tmp_path / "v.tif"), ("plan-world", world)):
        (tmp_path / name).mkdir()
        r = CliRunner().invoke(app, ["plan", "rows", str(src), "--out", str(tmp_path / name / "rows.plan")])
        assert r.exit_code == 0, r.output
    a = json.loads((tmp_path / "plan-dsm" / "rows.rows.geojson").read_text())
    b = json.loads((tmp_path / "plan-world" / "rows.rows.geojson").read_text())
    assert "crs" not in a and "crs" not in b
    assert len(a["features"]) == len(b["features"]) == len(wj["vine_rows_enu"])
    for fa, fb in zip(a["features"], b["features"], strict=True):
        assert fa["properties"] == fb["properties"]
        assert np.allclose(fa["geometry"]["coordinates"], fb["geometry"]["coordinates"], atol=3e-8)  # ~2-3 mm
    (tmp_path / "m.yaml").write_text(yaml.safe_dump({
        "name": "auto-spray", "vehicle": "x500-sprayer", "tank_fill_l": 0.3, "max_duration_s": 60,
        "phases": [{"type": "takeoff", "altitude_agl_m": 2.5},
                   {"type": "spray", "rows": "world", "height_agl_m": 2.0, "speed_mps": 2.0, "flow_lps": 0.05,
                    "until": "empty"},
                   {"type": "land"}],
        # 0.3 L sprays part of the field (no dose checks); a fair share lands on the detected rows' canopy bands
        "dose": {"check": False},
        "checks": [{"name": "on_rows", "quantity": "metric:deposit_on_rows_fraction", "op": ">=", "bound": 0.15},
                   {"name": "drain", "quantity": "metric:drain_time_ratio", "op": "between", "bound": [0.95, 1.1]}],
    }))
    s = run_mission(RunRequest(tmp_path / "m.yaml", world, tmp_path / "runs", seed=2))
    assert s.passed, (s.status, s.status_message, [(c["name"], c["value"], c["passed"]) for c in s.checks])
    summ = json.loads((Path(s.run_dir) / "summary.json").read_text())
    rows = summ["world"]["rows_enu"]
    assert rows == wj["vine_rows_enu"]  # the run flies the rows world build found
    for row in rows:  # every detected row runs at ~20 deg
        (x0, y0), (x1, y1) = row[0], row[-1]
        d = math.degrees(math.atan2(y1 - y0, x1 - x0)) % 180
        assert min(abs(d - 20.0), 180 - abs(d - 20.0)) < 2.5


def test_old_rows_auto_worlds_get_the_same_rows_at_run_time(tmp_path: Path) -> None:
    """A world built before rows were detected at build time (rows_auto, no rows): the run detects them on the
    world's height grid with the same detector (in the run set-up, on a copy of the world), and finds the rows world
    build finds on the DSM."""
    from shapely.geometry import LineString

    from vinecli.sim.setup import prepare_run, resolve_rows
    from vinecli.specs.mission import MissionSpec
    from vinecli.world import build_world, load_world

    vineyard_tif(tmp_path / "v.tif")
    (tmp_path / "w.yaml").write_text(yaml.safe_dump({
        "name": "auto-rows", "terrain": {"type": "dsm", "path": "v.tif", "format": "heightmap", "size": 257},
        "vehicle": "x500-sprayer", "spawn": {"x_m": 0.0, "y_m": 1.33}, "rows": "auto"}))
    w = load_world(build_world(tmp_path / "w.yaml", tmp_path / "world"))
    built = [list(map(tuple, r)) for r in w.vine_rows_enu]
    w.vine_rows_enu = []
    found = resolve_rows(w)
    assert w.vine_rows_enu == []  # the loaded world is not changed
    assert len(found.vine_rows_enu) == len(built)
    for a, b in zip(found.vine_rows_enu, built, strict=True):  # the heightmap grid (0.16 m) vs the DSM (0.1 m)
        la, lb = LineString(a), LineString(b)
        assert la.hausdorff_distance(lb) < 0.5 and lb.interpolate(0.5, normalized=True).distance(la) < 0.05
    with prepare_run(w, MissionSpec.model_validate({"name": "m", "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}]})) as run:
        assert run.world.vine_rows_enu == found.vine_rows_enu  # the run flies them
        assert run.rows == tuple(tuple((float(x), float(y)) for x, y in r) for r in found.vine_rows_enu)
