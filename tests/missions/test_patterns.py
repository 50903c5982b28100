"""Boustrophedon passes and vine-row detection (synthetic DSMs with known rows; real DSMs when present)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin
from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.missions.patterns import boustrophedon, detect_rows_grid, detect_rows_in_dsm, spray_mission


def ang_diff(a: float, b: float) -> float:
    """Difference of two undirected angles (deg, modulo 180)."""
    d = (a - b) % 180.0
    return min(d, 180.0 - d)


def vine_heights(X: np.ndarray, Y: np.ndarray, direction_deg: float, spacing: float, offset: float = 0.7,
                 seed: int = 0) -> np.ndarray:
    """Sloped ground + canopy ridges 1.2 m high along ``direction_deg`` every ``spacing`` m + noise."""
    th = math.radians(direction_deg)
    s = -math.sin(th) * X + math.cos(th) * Y
    canopy = 1.2 * np.clip(np.cos(2 * np.pi * (s - offset) / spacing), 0, None) ** 2
    rng = np.random.default_rng(seed)
    return 250.0 + 0.03 * X - 0.02 * Y + canopy + rng.normal(0, 0.05, X.shape)


@pytest.mark.parametrize(("direction", "spacing"), [(30.0, 2.5), (0.0, 2.0), (90.0, 3.0), (127.0, 2.8), (172.0, 1.2)])
def test_detect_rows_on_grid(direction: float, spacing: float) -> None:
    x = np.arange(0, 80, 0.25)
    y = np.arange(0, 60, 0.25)
    X, Y = np.meshgrid(x, y)
    z = vine_heights(X, Y, direction, spacing)
    d = detect_rows_grid(z, x, y)
    assert ang_diff(d.direction_deg, direction) <= 2.0
    assert d.spacing_m == pytest.approx(spacing, rel=0.05)
    # centre lines lie on the ridges and cover the field
    th = math.radians(direction)
    n = np.array([-math.sin(th), math.cos(th)])
    for row in d.rows:
        mid = np.mean(np.array(row), axis=0)
        assert math.cos(2 * np.pi * (np.dot(mid, n) - 0.7) / spacing) > 0.97
        for p in row:
            assert math.cos(2 * np.pi * (np.dot(p, n) - 0.7) / spacing) > 0.85
    field_width = np.ptp(np.array([[0, 0], [80, 0], [0, 60], [80, 60]]) @ n)
    assert len(d.rows) >= 0.8 * field_width / spacing


def test_detect_rows_with_expected_spacing_and_nodata_hole() -> None:
    x = np.arange(0, 50, 0.2)
    y = np.arange(0, 40, 0.2)
    X, Y = np.meshgrid(x, y)
    z = vine_heights(X, Y, 60.0, 2.2)
    z[(X - 25) ** 2 + (Y - 20) ** 2 < 36] = np.nan  # a pond without returns
    d = detect_rows_grid(z, x, y, spacing_m=2.0)
    assert ang_diff(d.direction_deg, 60.0) <= 2.0 and d.spacing_m == pytest.approx(2.2, rel=0.05)


def write_dsm(path: Path, direction_enu: float, spacing: float) -> None:
    """A UTM 32N GeoTIFF (0.2 m pixels) near Alba whose rows run ``direction_enu`` in the grid frame."""
    res = 0.2
    w, h = 300, 250
    x0, y0 = 424000.0, 4950000.0
    xs = (np.arange(w) + 0.5) * res
    ys = (h * res) - (np.arange(h) + 0.5) * res
    X, Y = np.meshgrid(xs, ys)
    z = vine_heights(X, Y, direction_enu, spacing).astype("float32")
    z[:3, :] = -9999.0
    with rasterio.open(path, "w", driver="GTiff", width=w, height=h, count=1, dtype="float32", crs="EPSG:32632",
                       transform=from_origin(x0, y0, res, res), nodata=-9999.0) as ds:
        ds.write(z, 1)


def test_detect_rows_in_geotiff(tmp_path: Path) -> None:
    tif = tmp_path / "vineyard.tif"
    write_dsm(tif, 35.0, 2.5)
    r = detect_rows_in_dsm(tif)
    # the frame is local metres along the CRS axes (as the terrain tools): the grid direction is the row direction
    assert ang_diff(r.detection.direction_deg, 35.0) <= 0.5
    assert r.detection.spacing_m == pytest.approx(2.5, rel=0.02)
    assert r.origin is not None and r.origin.lat == pytest.approx(44.7, abs=0.05)
    assert r.origin.lon == pytest.approx(8.04, abs=0.05)
    assert r.frame.crs == "EPSG:32632" and r.frame.centre == pytest.approx((424030.0, 4949975.0))
    assert len(r.detection.rows) >= 15


def test_cli_plan_rows_from_dsm(tmp_path: Path) -> None:
    tif = tmp_path / "vineyard.tif"
    write_dsm(tif, 100.0, 2.0)
    out = tmp_path / "spray.plan"
    mission = tmp_path / "spray.yaml"
    r = CliRunner().invoke(app, ["plan", "rows", str(tif), "--out", str(out), "--height", "2.5", "--flow", "0.04",
                                 "--mission", str(mission)])
    assert r.exit_code == 0, r.output
    assert "spacing 2.0" in r.output
    plan = json.loads(out.read_text())
    cmds = [it["command"] for it in plan["mission"]["items"]]
    assert cmds[0] == 22 and cmds[-1] == 21 and cmds.count(187) >= 20
    on = [it["params"][0] for it in plan["mission"]["items"] if it["command"] == 187]
    assert on[0] == 0.0 and on[1] == pytest.approx(0.4) and on[2] == 0.0  # off for the transit, 0.04 L/s of the
    # 0.1 L/s nozzle over the first row, then off
    assert "spray" in mission.read_text()


def test_cli_plan_rows_bad_input(tmp_path: Path) -> None:
    bad = tmp_path / "x.tif"
    bad.write_text("not a tiff")
    r = CliRunner().invoke(app, ["plan", "rows", str(bad), "--out", str(tmp_path / "p.plan")])
    assert r.exit_code == 2 and "x.tif" in r.output
    assert not (tmp_path / "p.plan").exists()


def test_boustrophedon_order_and_directions() -> None:
    rows = [[(0.0, 5.0), (10.0, 5.0)], [(10.0, 0.0), (0.0, 0.0)], [(0.0, 2.5), (10.0, 2.5)]]
    legs = boustrophedon(rows, start_xy=(-1.0, 6.0))
    assert [leg[0][1] for leg in legs] == [5.0, 2.5, 0.0]  # nearest side first
    assert legs[0][0] == (0.0, 5.0) and legs[1][0] == (10.0, 2.5) and legs[2][0] == (0.0, 0.0)
    m = spray_mission(rows, height_m=2.0, flow_lps=0.05)
    assert [p.type for p in m.phases] == ["takeoff", "spray", "land"]
