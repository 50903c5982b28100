"""A grower's GIS files -> a world -> a spray run -> GIS out: rows in a GeoPackage in UTM, the fence in KML (WGS84)
and a no-spray zone in GeoJSON with a buffer become the world (rows cut at the zone), the run sprays exactly those
rows, and `vinecli gis export` writes them back (RFC 7946 GeoJSON, GeoPackage) where they came from (< 1 cm)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyogrio
import pyogrio.raw
import pytest
import rasterio
import yaml
from pyproj import Transformer
from rasterio.transform import from_origin
from shapely.geometry import LineString, Polygon
from typer.testing import CliRunner

from vinecli.cli.app import app
from vinecli.errors import InputError

CRS = "EPSG:32632"
CX, CY = 424020.0, 4950020.0  # the DSM's centre (UTM 32N), the world's frame centre
TH = math.radians(20.0)  # rows along 20 deg from east
U, N = np.array([math.cos(TH), math.sin(TH)]), np.array([-math.sin(TH), math.cos(TH)])


def local(t: float, s: float) -> tuple[float, float]:
    """Local metres of (t along the rows, s across them)."""
    x, y = t * U + s * N
    return float(x), float(y)


ROWS_LOCAL = [[local(t, s) for t in (-12.0, 0.0, 12.0)] for s in (-2.5, 0.0, 2.5)]  # on the canopy ridges
ZONE_LOCAL = [local(-1.0, 1.0), local(1.0, 1.0), local(1.0, -1.0), local(-1.0, -1.0)]  # across the middle row
FENCE_LOCAL = [local(-17.0, -6.0), local(17.0, -6.0), local(17.0, 6.0), local(-17.0, 6.0)]


def utm(pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
    return [(x + CX, y + CY) for x, y in pts]


def lonlat(pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
    tr = Transformer.from_crs(CRS, "EPSG:4326", always_xy=True)
    return [tuple(map(float, tr.transform(x, y))) for x, y in utm(pts)]  # type: ignore[misc]


def write_dsm(path: Path) -> None:
    """40 m x 40 m, 0.1 m pixels, UTM 32N about (CX, CY); 1 m canopy ridges along 20 deg, 2.5 m apart."""
    res, n = 0.1, 401
    xs = (np.arange(n) + 0.5) * res - 20.05
    ys = 20.05 - (np.arange(n) + 0.5) * res
    X, Y = np.meshgrid(xs, ys)
    s = X * N[0] + Y * N[1]
    z = 240.0 + np.clip(np.cos(2 * np.pi * s / 2.5), 0, None) ** 2
    with rasterio.open(path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs=CRS,
                       transform=from_origin(CX - 20.05, CY + 20.05, res, res)) as ds:
        ds.write(z.astype("float32"), 1)


def write_layer(path: Path, geoms: list, crs: str, driver: str, props: dict | None = None) -> None:
    """A GIS file written with GDAL directly, as a grower's tools would."""
    names = list(props or {})
    cols = [np.array(v, dtype=object) for v in (props or {}).values()]
    pyogrio.raw.write(path, np.array([g.wkb for g in geoms], dtype=object), cols, names, driver=driver, crs=crs,
                      geometry_type=geoms[0].geom_type)


def grower_world(tmp: Path) -> Path:
    write_dsm(tmp / "field.tif")
    write_layer(tmp / "rows.gpkg", [LineString(utm(r)) for r in ROWS_LOCAL], CRS, "GPKG",
                {"name": [f"row {i + 1}" for i in range(3)]})
    write_layer(tmp / "fence.kml", [Polygon(lonlat(FENCE_LOCAL))], "EPSG:4326", "KML")
    write_layer(tmp / "stream.geojson", [Polygon(lonlat(ZONE_LOCAL))], "EPSG:4326", "GeoJSON")
    spawn = local(-14.5, 1.25)  # in a furrow, inside the fence
    (tmp / "w.yaml").write_text(yaml.safe_dump({
        "name": "grower", "terrain": {"type": "dsm", "path": "field.tif", "format": "heightmap", "size": 257},
        "vehicle": "x500-sprayer", "spawn": {"x_m": spawn[0], "y_m": spawn[1]},
        "geofence": {"max_altitude_agl_m": 15.0, "action": "hold"},
        "gis": {"rows": {"path": "rows.gpkg"}, "fence": {"path": "fence.kml"},
                "no_spray": [{"path": "stream.geojson", "buffer_m": 1.0}]}}))
    return tmp / "w.yaml"


def test_grower_files_become_the_world_the_job_and_the_gis_outputs(tmp_path: Path) -> None:
    from vinecli.runs import RunRequest, run_mission
    from vinecli.world import build_world

    world = build_world(grower_world(tmp_path), tmp_path / "world")
    wj = json.loads((world / "world.json").read_text())
    rows = wj["vine_rows_enu"]
    # the middle row is cut by the zone grown by 1 m (2 m + 2 x 1 m wide along the row): 4 stretches
    assert [s["row"] for s in wj["gis"]["row_sources"]] == [0, 1, 1, 2]
    assert [s["fid"] for s in wj["gis"]["row_sources"]] == [1, 2, 2, 3]
    for got, want in ((rows[0], ROWS_LOCAL[0]), (rows[3], ROWS_LOCAL[2])):
        assert np.max(np.abs(np.asarray(got) - np.asarray(want))) < 0.01
    a, b = LineString(rows[1]), LineString(rows[2])
    assert a.length == pytest.approx(10.0, abs=0.01) and b.length == pytest.approx(10.0, abs=0.01)
    assert LineString(ROWS_LOCAL[1]).hausdorff_distance(a) == pytest.approx(14.0, abs=0.01)  # the far end: 12 + 2
    assert Polygon(wj["geofence"]["polygon_enu"]).hausdorff_distance(Polygon(FENCE_LOCAL)) < 0.01
    assert wj["geofence"]["max_altitude_agl_m"] == 15.0  # the spec's fence settings kept
    assert Polygon(wj["gis"]["no_spray_enu"][0]).area == pytest.approx(16.0, rel=1e-3)

    (tmp_path / "m.yaml").write_text(yaml.safe_dump({
        "name": "grower-spray", "vehicle": "x500-sprayer", "max_duration_s": 120,
        "phases": [{"type": "takeoff", "altitude_agl_m": 2.5},
                   {"type": "spray", "rows": "world", "height_agl_m": 2.0, "speed_mps": 3.0, "rate_lpha": 20.0},
                   {"type": "land"}],
        "checks": [{"name": "covered", "quantity": "metric:row_coverage_fraction", "op": ">=", "bound": 0.9}]}))
    s = run_mission(RunRequest(tmp_path / "m.yaml", world, tmp_path / "runs", seed=1))
    assert s.passed, (s.status, s.status_message, [(c["name"], c["value"], c["passed"]) for c in s.checks])
    dep = json.loads((Path(s.run_dir) / "deposition.json").read_text())
    assert dep["metrics"]["deposit_in_no_spray_fraction"] < 1e-3  # the sections closed a footprint before the zone
    assert "dose_no_spray" in {c["name"] for c in s.checks}
    for r in dep["rows"]:  # both pieces of the cut row and the rows beside the zone get the asked rate
        assert abs(r["mean_rate_lpha"] / 20.0 - 1.0) <= 0.15 and r["covered_fraction"] == 1.0, r["row"]
    (_, end1), (start2, _) = dep["rows"][1]["planned_m"], dep["rows"][2]["planned_m"]
    assert end1 < 10.0 - 2.0 and start2 > 2.0  # judged up to where the full dose reaches without the zone
    assert dep["rows"][0]["not_judged_m"] and dep["rows"][3]["not_judged_m"]  # beside the zone: the taper

    r = CliRunner().invoke(app, ["gis", "export", str(s.run_dir), "--out", str(tmp_path / "out.geojson")])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(app, ["gis", "export", str(s.run_dir), "--out", str(tmp_path / "out.gpkg")])
    assert r.exit_code == 0, r.output
    fc = json.loads((tmp_path / "out.geojson").read_text())
    assert "crs" not in fc
    by = {k: [f for f in fc["features"] if f["properties"]["layer"] == k] for k in
          ("rows", "passes", "sprayed", "gaps", "deposition", "fence", "no_spray")}
    to_utm = Transformer.from_crs("EPSG:4326", CRS, always_xy=True)
    for f, want in ((by["rows"][0], ROWS_LOCAL[0]), (by["rows"][3], ROWS_LOCAL[2])):  # the grower's rows, in place
        got = [to_utm.transform(*c) for c in f["geometry"]["coordinates"]]
        assert np.max(np.abs(np.asarray(got) - np.asarray(utm(want)))) < 0.01
    layers = {name for name, _ in pyogrio.list_layers(tmp_path / "out.gpkg")}
    assert {"rows", "passes", "sprayed", "deposition", "fence", "no_spray"} <= layers
    info = pyogrio.read_info(tmp_path / "out.gpkg", layer="rows")
    assert info["crs"] == "EPSG:4326" and info["features"] == 4
    # the job sprayed exactly those rows: every stretch sprayed, the sprayer off over the zone (no pass inside it)
    assert len(by["sprayed"]) >= 4 and sum(f["properties"]["to_m"] - f["properties"]["from_m"]
                                           for f in by["sprayed"]) >= 0.9 * 44.0
    zone = Polygon([to_utm.transform(*c) for c in by["no_spray"][0]["geometry"]["coordinates"][0]])
    core = Polygon(utm(ZONE_LOCAL))
    assert zone.contains(core) and zone.area == pytest.approx(16.0, rel=1e-3)
    for p in by["passes"]:
        line = LineString([to_utm.transform(*c) for c in p["geometry"]["coordinates"]])
        assert line.intersection(zone).length < 0.3  # the valve closed before the zone (the pump's run-down aside)

    # outputs aimed at the inputs (the grower's files, even with --overwrite; the run; the world): exit 2, untouched
    before = (tmp_path / "rows.gpkg").read_bytes()
    run_dir = Path(s.run_dir)
    for target in (tmp_path / "rows.gpkg", tmp_path / "stream.geojson", run_dir / "x.geojson", world / "x.gpkg"):
        r = CliRunner().invoke(app, ["gis", "export", str(s.run_dir), "--out", str(target), "--overwrite"])
        assert r.exit_code == 2 and "input" in r.output and len(r.output.strip().splitlines()) == 1, r.output
    assert (tmp_path / "rows.gpkg").read_bytes() == before
    assert not (run_dir / "x.geojson").exists() and not (world / "x.gpkg").exists()


def test_a_plan_spraying_up_to_the_zone_fails_the_no_spray_check(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """The same job with the plan's clearance at the zone set to 0 (the passes end at the zone's edge, as before the
    clearance): the footprint and the pump's run-down put liquid into the zone, and the default check says so."""
    import vinecli.rows.plan
    from vinecli.runs import RunRequest, run_mission
    from vinecli.world import build_world

    monkeypatch.setattr(vinecli.rows.plan, "clearance_m", lambda pattern, end_margin_m: 0.0)
    world = build_world(grower_world(tmp_path), tmp_path / "world")
    (tmp_path / "m.yaml").write_text(yaml.safe_dump({
        "name": "grower-no-clearance", "vehicle": "x500-sprayer", "max_duration_s": 120,
        "phases": [{"type": "takeoff", "altitude_agl_m": 2.5},
                   {"type": "spray", "rows": "world", "height_agl_m": 2.0, "speed_mps": 3.0, "rate_lpha": 20.0},
                   {"type": "land"}]}))
    s = run_mission(RunRequest(tmp_path / "m.yaml", world, tmp_path / "runs", seed=1))
    check = next(c for c in s.checks if c["name"] == "dose_no_spray")
    assert not s.passed and not check["passed"] and check["value"] > 0.01, check  # 3.5 % of the liquid


def test_bad_gis_inputs_exit_2_naming_the_feature_and_write_nothing(tmp_path: Path) -> None:
    from vinecli.world import build_world

    spec = grower_world(tmp_path)
    far = [local(-12.0, 30.0), local(12.0, 30.0)]  # 30 m off the rows: outside the 40 m DSM
    write_layer(tmp_path / "rows.gpkg", [LineString(utm(r)) for r in [ROWS_LOCAL[0], far]], CRS, "GPKG")
    with pytest.raises(InputError, match=r"layer 'rows' feature 2: row point .* outside the terrain"):
        build_world(spec, tmp_path / "world")
    assert not (tmp_path / "world").exists()
    write_layer(tmp_path / "rows.gpkg", [LineString(utm(r)) for r in ROWS_LOCAL], CRS, "GPKG")
    two = [Polygon(lonlat(FENCE_LOCAL)), Polygon(lonlat(ZONE_LOCAL))]
    write_layer(tmp_path / "fence.kml", two, "EPSG:4326", "KML")
    with pytest.raises(InputError, match="the fence must be one polygon, found 2"):
        build_world(spec, tmp_path / "world")
    assert not (tmp_path / "world").exists()
    d = yaml.safe_load(spec.read_text())
    d["rows"] = [[[0.0, 0.0], [1.0, 1.0]]]
    spec.write_text(yaml.safe_dump(d))
    r = CliRunner().invoke(app, ["world", "build", str(spec), "--out", str(tmp_path / "world")])
    assert r.exit_code == 2 and "rows given twice" in r.output
