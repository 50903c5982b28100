"""Hostile inputs end with exit 2 and one line naming the file and the problem,
early, within bounded memory, and leave no folder behind.

* class 1: JSON nested 200,000 levels deep (a .plan, a world's world.json, a run's summary.json) is bad input,
  not a RecursionError;
* class 9: sizes no real field reaches (a fence of 10^6 vertices, a .plan of 10^6 items, rows of 10^6 vertices)
  are refused at read, naming the limit and the real figure, in seconds and well under 1.5 GB; a YAML file that
  is merely large is not called an alias bomb;
* class 10: a directory or a FIFO given as a GIS file is named for what it is; a Shapefile without its .dbf is
  refused and its sidecars are inputs (hashed in the manifest); NaN coordinates, garbage in a DataFlash log and
  a spawn outside a heightmap print one line, no warning of shapely, pymavlink or logging;
* class 8: ``world build --out new/a/b/w`` that fails leaves no ``new/``.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from attack_kit import PLAN, SAMPLE_DSM, cli, error_line, fingerprint
from memguard import run_child
from shapely.geometry import LineString, Polygon

from tests.gis.test_gis_world import FENCE_LOCAL, ROWS_LOCAL, grower_world, lonlat, utm, write_layer

DEEP = 200_000


@pytest.fixture(scope="module")
def grower(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("grower")
    grower_world(d)
    return d


def _spec(grower: Path, name: str, **gis: object) -> Path:
    spec = yaml.safe_load((grower / "w.yaml").read_text())
    spec["gis"] = {**spec["gis"], **gis}
    p = grower / f"{name}.yaml"
    p.write_text(yaml.safe_dump(spec))
    return p


# ---------------------------------------------------------------- class 1: nesting
def test_a_plan_nested_200000_deep_is_bad_input(rows_world: Path, tmp_path: Path) -> None:
    p = tmp_path / "deep.plan"
    p.write_text('{"fileType": "Plan", "version": 1, "mission": ' + "[" * DEEP + "]" * DEEP + "}")
    r = cli("plan", "import", p, "--world", rows_world, "--out", tmp_path / "m.yaml")
    assert r.exit_code == 2 and "nested too deeply" in error_line(r)
    assert not (tmp_path / "m.yaml").exists()


@pytest.mark.parametrize("where", ["world.json", "summary.json"])
def test_a_vinecli_folder_whose_json_is_nested_deep_is_bad_input(rows_world: Path, tmp_path: Path, where: str) -> None:
    import shutil

    from attack_kit import mission

    deep = "[" * DEEP + "]" * DEEP
    if where == "world.json":
        w = tmp_path / "world"
        shutil.copytree(rows_world, w)
        (w / "world.json").write_text('{"name": ' + deep + "}")
        r = cli("run", "mission", mission(tmp_path), "--world", w, "--out", tmp_path / "runs")
    else:
        run = tmp_path / "runs" / "r"
        run.mkdir(parents=True)
        (run / "summary.json").write_text('{"run_id": ' + deep + "}")
        r = cli("gis", "export", run, "--out", tmp_path / "x.geojson")
    assert r.exit_code == 2 and "nested too deeply" in error_line(r), r.output


# ---------------------------------------------------------------- class 9: sizes
def test_a_fence_of_a_million_vertices_is_refused_early(grower: Path, tmp_path: Path) -> None:
    cx, cy = np.array(lonlat(FENCE_LOCAL)).mean(axis=0)
    a = np.linspace(0, 2 * np.pi, 1_000_000, endpoint=False)
    poly = Polygon(np.column_stack([cx + 1e-4 * np.cos(a), cy + 5e-5 * np.sin(a)]))
    write_layer(grower / "huge.geojson", [poly], "EPSG:4326", "GeoJSON")
    spec = _spec(grower, "huge", fence={"path": "huge.geojson"})
    t0 = time.monotonic()
    r = cli("world", "build", spec, "--out", tmp_path / "w")
    assert r.exit_code == 2, r.output
    line = error_line(r)
    assert "1,000,000 vertices in one polygon: at most 10,000" in line and "huge.geojson" in line
    assert time.monotonic() - t0 < 60 and not (tmp_path / "w").exists()


def test_rows_of_a_million_vertices_are_refused(grower: Path, tmp_path: Path) -> None:
    lines = [LineString(utm([(x, s) for x in np.linspace(-12, 12, 250_000)])) for s in (-2.5, 0.0, 2.5, 5.0)]
    write_layer(grower / "dense.gpkg", lines, "EPSG:32632", "GPKG")
    r = cli("world", "build", _spec(grower, "dense", rows={"path": "dense.gpkg"}), "--out", tmp_path / "w")
    assert r.exit_code == 2 and "row vertices: at most 100,000" in error_line(r)


def test_inline_fences_and_rows_have_the_same_limits(tmp_path: Path) -> None:
    n = 10_001
    fence = [[float(np.cos(t)) * 50, float(np.sin(t)) * 50] for t in np.linspace(0, 6.28, n, endpoint=False)]
    (tmp_path / "w.yaml").write_text(yaml.safe_dump({"name": "w", "terrain": {"type": "flat"}, "origin": {
        "lat": 44.7, "lon": 8.03, "alt": 250.0}, "geofence": {"polygon_enu": fence}}))
    r = cli("world", "build", tmp_path / "w.yaml", "--out", tmp_path / "w")
    assert r.exit_code == 2 and "10,001 fence vertices: at most 10,000" in error_line(r)


def _plan_of(items: int) -> dict:
    plan = json.loads(PLAN.read_text())
    wp = next(it for it in plan["mission"]["items"] if it.get("command") == 16)
    plan["mission"]["items"] = plan["mission"]["items"][:2] + [wp] * items
    return plan


def test_a_plan_of_a_million_items_is_refused_in_seconds_and_little_memory(rows_world: Path, tmp_path: Path) -> None:
    p = tmp_path / "huge.plan"
    p.write_text(json.dumps(_plan_of(1_000_000)))  # ~150 MB
    code = ("import sys; from vinecli.cli.app import app; sys.argv = ['vinecli'] + sys.argv[1:]; app()")
    t0 = time.monotonic()
    r = run_child([sys.executable, "-c", code, "plan", "import", str(p), "--world", str(rows_world), "--out",
                   str(tmp_path / "m.yaml")], timeout=300)
    took = time.monotonic() - t0
    assert r.returncode == 2, r.stderr[-2000:]
    assert "at most 16 MB" in r.stderr and "huge.plan" in r.stderr
    assert took < 30 and r.peak_rss_mb < 600, (took, r.peak_rss_mb)
    print(f"10^6-item .plan refused in {took:.1f} s, peak {r.peak_rss_mb:.0f} MB")


def test_a_plan_over_the_item_limit_names_the_limit(rows_world: Path, tmp_path: Path) -> None:
    p = tmp_path / "many.plan"
    p.write_text(json.dumps(_plan_of(10_001)))
    r = cli("plan", "import", p, "--world", rows_world, "--out", tmp_path / "m.yaml")
    assert r.exit_code == 2 and "mission items: at most 10,000" in error_line(r)


def test_a_large_yaml_without_aliases_is_not_called_an_alias_bomb(flat_world_dir: Path, tmp_path: Path) -> None:
    # 400,000 waypoints written as text (PyYAML's emitter takes minutes for them): 1.2 million values, no alias
    wps = "".join(f"  - [{float(i % 50)}, {float(i // 50 % 50)}, 2.0]\n" for i in range(400_000))
    (tmp_path / "big.yaml").write_text("name: big\nvehicle: x500-sprayer\nphases:\n- {type: takeoff, altitude_agl_m: 2.0}\n"
                                       "- type: waypoints\n  waypoints_enu:\n" + wps)
    r = cli("run", "mission", tmp_path / "big.yaml", "--world", flat_world_dir, "--out", tmp_path / "runs")
    assert r.exit_code == 2
    line = error_line(r)
    assert "expands to more than 1,000,000 values" in line and "alias" not in line


# ---------------------------------------------------------------- class 10: one line, the right line
@pytest.mark.parametrize("what", ["a directory", "a FIFO"])
def test_a_gis_file_that_is_not_a_file_is_named_for_what_it_is(grower: Path, tmp_path: Path, what: str) -> None:
    bad = grower / f"bad-{what[2:]}.geojson"
    bad.mkdir() if what == "a directory" else os.mkfifo(bad)
    r = cli("world", "build", _spec(grower, f"bad-{what[2:]}", fence={"path": bad.name}), "--out", tmp_path / "w")
    assert r.exit_code == 2 and f"GIS file is {what}, not a regular file" in error_line(r)


def test_a_shapefile_without_its_dbf_is_refused_and_its_sidecars_are_inputs(grower: Path, tmp_path: Path) -> None:
    write_layer(grower / "rows.shp", [LineString(utm(r)) for r in ROWS_LOCAL], "EPSG:32632", "ESRI Shapefile",
                {"name": ["a", "b", "c"]})
    r = cli("world", "build", _spec(grower, "shp", rows={"path": "rows.shp"}), "--out", tmp_path / "w")
    assert r.exit_code == 0, r.output
    inputs = {Path(i["path"]).name: i for i in json.loads((tmp_path / "w" / "manifest.json").read_text())["inputs"]}
    for part in ("rows.shp", "rows.shx", "rows.dbf", "rows.prj"):
        assert "sha256" in inputs[part], part
    (grower / "rows.dbf").rename(grower / "rows.dbf.away")
    r = cli("world", "build", _spec(grower, "shp", rows={"path": "rows.shp"}), "--out", tmp_path / "w2")
    assert r.exit_code == 2 and "Shapefile without its .dbf" in error_line(r)


def test_nan_coordinates_are_one_line_without_a_crs_hint(grower: Path, tmp_path: Path) -> None:
    (grower / "nan.geojson").write_text(json.dumps({"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [
            [[8.0, 44.0], ["NaN", 44.0], [8.1, 44.1], [8.0, 44.0]]]}}]}).replace('"NaN"', "NaN"))
    r = cli("world", "build", _spec(grower, "nan", fence={"path": "nan.geojson"}), "--out", tmp_path / "w")
    assert r.exit_code == 2
    line = error_line(r)  # one line: no RuntimeWarning of shapely before it
    assert "is not a number" in line and "CRS" not in line


def test_garbage_after_a_dataflash_header_is_one_line(tmp_path: Path) -> None:
    from tests.flightlog.synthetic_log import synthetic_log
    from vinecli.flightlog.dataflash_write import write_dataflash

    head = write_dataflash(synthetic_log(), tmp_path / "full.bin").read_bytes()[:3000]
    (tmp_path / "junk.bin").write_bytes(head + np.random.default_rng(1).integers(0, 256, 20000, np.uint8).tobytes())
    code = ("import sys; from vinecli.cli.app import app; sys.argv = ['vinecli'] + sys.argv[1:]; app()")
    r = run_child([sys.executable, "-c", code, "vehicle", "fit", str(tmp_path / "junk.bin"), "--out",
                   str(tmp_path / "fit")], timeout=300)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip() and "compiled kernel" not in ln and "_native" not in ln]
    assert r.returncode == 2 and len(lines) == 1 and "junk.bin" in lines[0], r.stderr[-3000:]


def test_a_spawn_outside_a_heightmap_is_one_line(tmp_path: Path) -> None:
    """The 3 cm sample DSM resampled to 65 x 65 warns that rows may be lost; the spawn's error is still one line."""
    (tmp_path / "far.yaml").write_text(yaml.safe_dump({
        "name": "far", "terrain": {"type": "dsm", "path": str(SAMPLE_DSM), "format": "heightmap", "size": 65},
        "spawn": {"x_m": 500.0, "y_m": 0.0}}))
    r = cli("world", "build", tmp_path / "far.yaml", "--out", tmp_path / "w")
    assert r.exit_code == 2 and "outside the terrain" in error_line(r)


# ---------------------------------------------------------------- class 8: folders made by a failed command
def test_a_failed_build_leaves_no_folder_it_made(grower: Path, tmp_path: Path) -> None:
    spec = _spec(grower, "missing", rows={"path": "nowhere.gpkg"})
    before = fingerprint(grower)
    r = cli("world", "build", spec, "--out", tmp_path / "new" / "a" / "b" / "w")
    assert r.exit_code == 2 and "nowhere.gpkg" in error_line(r)
    assert not (tmp_path / "new").exists() and fingerprint(grower) == before
