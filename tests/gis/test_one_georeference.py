"""One georeference (docs/architecture.md "Frames"): a world built from a DSM with a CRS lies on the CRS grid, and
every path out of it to latitude/longitude goes through that CRS. A row drawn in a GIS on the real sample DSM
(UTM 16N at Hancock, WI: the grid is 1.770 deg off true north there) lands on the same ground in the world, in the
``.plan``, in the GNSS fixes and in ``gis export``: within a few cm (the topocentric tangent plane used before put a
point 30 m from the centre 0.93 m away)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import rasterio
import yaml
from pyproj import Proj, Transformer
from repo_paths import REPO
from shapely.geometry import LineString, Point
from typer.testing import CliRunner

from vinecli.cli.app import app

SAMPLE = REPO / "worlds" / "sample" / "fieldimager_potato_plots_dsm_3cm_utm16n.tif"
UTM = "EPSG:32616"


def _centre() -> tuple[float, float]:
    with rasterio.open(SAMPLE) as ds:
        b = ds.bounds
    return (b.left + b.right) / 2, (b.bottom + b.top) / 2


#: rows drawn in QGIS on the sample DSM, UTM 16N metres from the raster centre (the plot's east side)
ROWS_UTM = [[(5.0, -28.0), (6.2, 28.0)], [(6.8, -28.0), (8.0, 28.0)]]


def grower_world(tmp: Path) -> tuple[Path, list[list[tuple[float, float]]]]:
    """A world on the sample DSM whose rows come from a GeoJSON (WGS84) drawn in UTM; returns the spec and the rows
    in UTM."""
    cx, cy = _centre()
    rows = [[(cx + x, cy + y) for x, y in r] for r in ROWS_UTM]
    to_ll = Transformer.from_crs(UTM, "EPSG:4326", always_xy=True)
    fc = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "id": i + 1, "properties": {"name": f"row {i + 1}"},
         "geometry": {"type": "LineString", "coordinates": [list(to_ll.transform(x, y)) for x, y in r]}}
        for i, r in enumerate(rows)]}
    (tmp / "rows.geojson").write_text(json.dumps(fc))
    (tmp / "w.yaml").write_text(yaml.safe_dump({
        "name": "one-georef", "terrain": {"type": "dsm", "path": str(SAMPLE), "format": "tiles", "max_error_m": 0.1},
        "vehicle": "x500-sprayer", "spawn": {"x_m": -8.8, "y_m": -25.0, "yaw_deg": 90.0},
        "gis": {"rows": {"path": "rows.geojson"}}}))
    return tmp / "w.yaml", rows


def test_the_grid_convergence_at_the_sample_field() -> None:
    """GeoFrame's convergence is the CRS's (pyproj: meridian convergence -1.770 deg = grid north 1.770 deg west of
    true north); its per-step quadratic matches the exact CRS map within 0.1 mm over 400 m."""
    from vinecli.geo import GeoFrame

    cx, cy = _centre()
    lon, lat = Transformer.from_crs(UTM, "EPSG:4326", always_xy=True).transform(cx, cy)
    g = GeoFrame(lat, lon, 330.0, crs=UTM, crs_centre=(cx, cy))
    conv = Proj(UTM).get_factors(lon, lat).meridian_convergence
    assert math.degrees(g.convergence_rad) == pytest.approx(-conv, abs=1e-4)
    assert math.degrees(g.convergence_rad) == pytest.approx(1.770, abs=0.001)
    m_lat, m_lon = g.metres_per_degree
    for x, y in ((30.0, 0.0), (0.0, -30.0), (250.0, 400.0), (-400.0, -400.0)):
        ex, fa = g.enu_to_geodetic(x, y, 1.0), g.enu_to_geodetic_fast(x, y, 1.0)
        assert abs(ex[0] - fa[0]) * m_lat < 1e-4 and abs(ex[1] - fa[1]) * m_lon < 1e-4 and ex[2] == fa[2]
        back = g.geodetic_to_enu_fast(*ex)
        assert abs(back[0] - x) < 1e-4 and abs(back[1] - y) < 1e-4 and back[2] == pytest.approx(1.0)


def test_a_row_drawn_in_a_gis_lands_on_the_same_ground_in_the_world_the_plan_the_gnss_and_gis_export(
        tmp_path: Path) -> None:
    from vinecli.gis.georef import world_dir_georef
    from vinecli.world import build_world, load_world

    spec, rows_utm = grower_world(tmp_path)
    world = build_world(spec, tmp_path / "world")
    w = load_world(world)
    cx, cy = _centre()
    # the world: the CRS grid about the raster centre (no rotation)
    for got, want in zip(w.vine_rows_enu, ROWS_UTM, strict=True):
        assert np.max(np.abs(np.asarray(got) - np.asarray(want))) < 0.01
    # GNSS fixes (the per-step path) and gis export (the GIS path): the drawn longitude/latitude
    to_utm = Transformer.from_crs("EPSG:4326", UTM, always_xy=True)
    georef = world_dir_georef(world)
    for row, drawn in zip(w.vine_rows_enu, rows_utm, strict=True):
        for (x, y), (ux, uy) in zip(row, drawn, strict=True):
            lat, lon, _ = w.origin.enu_to_geodetic_fast(x, y, 0.0)
            assert math.dist(to_utm.transform(lon, lat), (ux, uy)) < 0.01
            (glon, glat), = georef.to_lonlat([(x, y)])
            assert math.dist(to_utm.transform(glon, glat), (ux, uy)) < 0.01

    # the .plan: every waypoint on a row lies on the drawn line (the topocentric plane put them up to 0.9 m off)
    out = tmp_path / "plan" / "rows.plan"
    out.parent.mkdir()
    r = CliRunner().invoke(app, ["plan", "rows", str(world), "--out", str(out), "--tank", "0"])
    assert r.exit_code == 0, r.output
    items = json.loads(out.read_text())["mission"]["items"]
    wps = [to_utm.transform(it["params"][5], it["params"][4]) for it in items if it.get("command") == 16]
    lines = [LineString(r) for r in rows_utm]
    on_row = [min(ln.distance(Point(p)) for ln in lines) for p in wps]
    near = [d for d in on_row if d < 0.5]
    assert len(near) >= 2 * len(lines), on_row  # both ends of each row
    assert max(near) < 0.03, near

    # and back: the .plan imported into the world puts its waypoints on the world's rows
    from vinecli.mavlink.mission_items import item_enu

    world_lines = [LineString(r) for r in w.vine_rows_enu]
    for it in items:
        if it.get("command") == 16:
            e, n = item_enu(w.origin, it["params"][4], it["params"][5], degrees=True)
            d = min(ln.distance(Point(e, n)) for ln in world_lines)
            assert d < 0.03 or d > 0.5
