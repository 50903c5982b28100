"""Segment rates flown by the built-in autopilot on the bundled sample field (real loop, pump and deposition), as
pipelines/dose.yaml runs them: a leaf-wall-area dose on the canopy measured on the DSM, a three-zone GeoPackage
prescription in Web Mercator and an ISO-XML TaskData grid. Each segment gets its own rate (>= 90 % of the sprayed
row length within ±10 %), no step overruns its pump-lag bound, the saving against a uniform rate is stated; the
as-applied outputs read back with GDAL's own tools (gdalinfo, gdallocationinfo, ogr2ogr) and the ISO-XML TimeLog
with the isoxml package and its binary layout."""

from __future__ import annotations

import csv
import io
import json
import struct
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.repo_paths import REPO
from vinecli.runs.mission import run_mission
from vinecli.runs.request import RunRequest

MISSIONS = REPO / "pipelines" / "missions" / "dose"


@pytest.fixture(scope="module")
def dose_runs(sample_world_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("dose-runs")
    return {m: Path(run_mission(RunRequest(MISSIONS / f"{m}.yaml", sample_world_dir, out)).run_dir) for m in ("lwa", "zones", "grid")}


def _summary(run: Path) -> dict[str, Any]:
    return json.loads((run / "summary.json").read_text())


def _as_applied(run: Path) -> dict[str, Any]:
    return json.loads((run / "as_applied.json").read_text())


@pytest.mark.parametrize("case", ["lwa", "zones", "grid"])
def test_each_segment_at_its_own_rate(dose_runs: dict[str, Path], case: str) -> None:
    s = _summary(dose_runs[case])
    failed = [(c["name"], c["value"]) for c in s["checks"] if not c["passed"]]
    assert s["passed"], failed
    names = {c["name"] for c in s["checks"]}
    assert {"dose_as_applied", "dose_zone_error", "dose_transitions", "dose_gaps_sprayed"} <= names
    assert "dose_row_rates" not in names  # no one asked rate to judge the rows against
    m, a = s["metrics"], s["as_applied"]
    assert m["dose_in_band_fraction"] >= 0.9 and m["dose_transitions_over_bound"] == 0 and m["dose_gaps_sprayed"] == 0
    assert a["follows"]["autopilot"] == "builtin" and "pump's lag" in a["follows"]["method"]
    segs = [g for g in _as_applied(dose_runs[case])["segments"] if g["prescribed_lpha"] > 0]
    presc = np.array([g["prescribed_lpha"] for g in segs])
    pump = np.array([g["pump_lpha"] for g in segs])
    assert presc.max() / presc.min() > 1.5  # the rates differ along the rows...
    assert np.corrcoef(presc, pump)[0, 1] > 0.95  # ... and the pump follows them
    p = a["product"]
    assert p["saving_l"] == pytest.approx(p["uniform_l"] - p["applied_l"])
    assert 5.0 < p["saving_pct"] == pytest.approx(100 * p["saving_l"] / p["uniform_l"])
    assert p["applied_l"] == pytest.approx(p["prescribed_l"], rel=0.03)


def test_three_zones_of_the_geopackage(dose_runs: dict[str, Path]) -> None:
    zones = {z["zone"]: z for z in _summary(dose_runs["zones"])["as_applied"]["zones"]}
    assert set(zones) == {"14 L/ha", "22 L/ha", "30 L/ha"}
    assert all(abs(z["pump_error"]) <= 0.05 and abs(z["deposit_error"]) <= 0.15 for z in zones.values())
    crs = subprocess.run(["ogrinfo", "-so", str(REPO / "pipelines" / "maps" / "sample-zones.gpkg"), "zones"],
                         capture_output=True, text=True, check=True).stdout
    assert "3857" in crs and "Feature Count: 3" in crs  # the map is in Web Mercator, the DSM in UTM 16N


def _gdal_json(path: Path) -> dict[str, Any]:
    return json.loads(subprocess.run(["gdalinfo", "-json", str(path)], capture_output=True, text=True,
                                     check=True).stdout)


def _ogr_csv(path: Path, layer: str) -> list[dict[str, str]]:
    out = subprocess.run(["ogr2ogr", "-f", "CSV", "/vsistdout/", str(path), layer, "-lco", "GEOMETRY=AS_XY"],
                         capture_output=True, text=True, check=True).stdout
    return list(csv.DictReader(io.StringIO(out)))


def test_as_applied_outputs_read_with_gdal(dose_runs: dict[str, Path], sample_world_dir: Path) -> None:
    from vinecli.gis.georef import world_dir_georef

    run = dose_runs["zones"]
    doc = _as_applied(run)
    info = _gdal_json(run / "as_applied.tif")
    dep = _gdal_json(run / "deposition.tif")
    assert "UTM zone 16N" in info["coordinateSystem"]["wkt"]
    assert info["geoTransform"] == dep["geoTransform"] and info["size"] == dep["size"]  # the deposition grid
    assert [b["description"] for b in info["bands"]] == ["prescribed_lpha", "pump_lpha", "deposit_lpha", "pump_error_pct"]
    georef = world_dir_georef(sample_world_dir)
    segs = doc["segments"][::7]
    lonlat = georef.to_lonlat([tuple(g["mid_enu"]) for g in segs])
    for g, (lon, lat) in zip(segs, lonlat, strict=True):
        got = subprocess.run(["gdallocationinfo", "-wgs84", "-valonly", str(run / "as_applied.tif"), repr(lon), repr(lat)],
                             capture_output=True, text=True, check=True).stdout.split()
        assert float(got[0]) == pytest.approx(g["prescribed_lpha"], rel=1e-5)
        assert float(got[1]) == pytest.approx(g["pump_lpha"], rel=1e-4)
        assert float(got[3]) == pytest.approx(100 * g["pump_error"], abs=0.006)  # the JSON keeps 4 decimals
    rows = _ogr_csv(run / "as_applied.gpkg", "per_segment")
    assert len(rows) == len(doc["segments"])
    for r, g, (lon, lat) in zip(rows, doc["segments"], georef.to_lonlat([tuple(g["mid_enu"]) for g in doc["segments"]]),
                                strict=True):
        assert float(r["X"]) == pytest.approx(lon, abs=1e-8) and float(r["Y"]) == pytest.approx(lat, abs=1e-8)
        assert float(r["prescribed_lpha"]) == pytest.approx(g["prescribed_lpha"], rel=1e-4)
        assert float(r["pump_lpha"]) == pytest.approx(g["pump_lpha"], rel=1e-3)
    sec = _ogr_csv(run / "as_applied.gpkg", "per_second")
    t = [float(r["t_s"]) for r in sec]
    assert len(sec) == len(doc["per_second"]) > 30 and np.allclose(np.diff(t), 1.0, atol=0.05)
    gpkg = subprocess.run(["ogrinfo", "-so", str(run / "as_applied.gpkg"), "per_second"], capture_output=True,
                          text=True, check=True).stdout
    assert "4326" in gpkg and "Point" in gpkg
    overlays = json.loads((run / "dose_map" / "overlays.json").read_text())
    assert [ly["name"] for ly in overlays["layers"]] == ["prescription", "as_applied", "error"]
    for ly in overlays["layers"]:
        (s, w), (n, e) = ly["bounds"]
        assert s < n and w < e and (run / "dose_map" / ly["png"]).stat().st_size > 500
        fc = json.loads((run / "dose_map" / ly["geojson"]).read_text())
        assert len(fc["features"]) == len(doc["segments"])


def test_isoxml_timelog(dose_runs: dict[str, Path]) -> None:
    """The grid run's TimeLog: the task references TLG00001 (its length), the header says what each record holds,
    and the binary records are the 1 Hz log (DDI 1 the prescription, DDI 2 the pump, mm³/m²)."""
    import isoxml.models.base.v4 as iso
    from isoxml.util.isoxml_io import isoxml_from_path
    from xsdata.formats.dataclass.parsers import XmlParser

    run = dose_runs["grid"]
    folder = run / "as_applied_taskdata"
    td, refs = isoxml_from_path(folder)
    task = td.tasks[0]
    assert task.grids and task.time_logs[0].filename == "TLG00001"
    blob = (folder / "TLG00001.BIN").read_bytes()
    assert task.time_logs[0].filelength == len(blob) and "GRD00001" in refs
    header = XmlParser().from_path(folder / "TLG00001.XML", iso.Time)
    assert [int.from_bytes(d.process_data_ddi, "big") for d in header.data_log_values] == [1, 2]
    assert header.positions[0].status == iso.PositionStatus.SimulateMode  # fixed: not in the records
    log = _as_applied(run)["per_second"]
    i, recs = 0, []
    while i < len(blob):
        ms, day, lat, lon, n = struct.unpack_from("<IHiiB", blob, i)
        i += 15
        vals = {}
        for _ in range(n):
            k, v = struct.unpack_from("<Bi", blob, i)
            vals[k] = v
            i += 5
        recs.append((ms, day, lat * 1e-7, lon * 1e-7, vals))
    assert len(recs) == len(log)
    assert all(abs(r[4][0] * 0.01 - p["prescribed_lpha"]) < 0.006 for r, p in zip(recs, log, strict=True))
    assert all(1 not in r[4] or abs(r[4][1] * 0.01 - p["pump_lpha"]) < 0.006 for r, p in zip(recs, log, strict=True))
    dt = np.diff([r[0] for r in recs]) / 1000.0
    assert np.allclose(dt, np.diff([p["t_s"] for p in log]), atol=0.002)
    assert all(44.11 < r[2] < 44.12 and -89.55 < r[3] < -89.53 for r in recs)  # on the sample field


def test_dose_figures(dose_runs: dict[str, Path]) -> None:
    """fig26 (canopy, prescription, applied, error maps) and fig27 (error histogram, transitions, product) of a
    dosed run: drawn at their size, not blank."""
    from vinecli.report.plots import expected_size, png_size, render_figures

    figs = render_figures(str(dose_runs["lwa"]), only=["fig26", "fig27"])
    for fid, f in figs.items():
        assert f["png"], f["note"]
        assert png_size(f["png"]) == expected_size(fid) and len(f["png"]) > 20_000


GAP_WORLD = """\
name: gaps
terrain: {type: dsm, path: vineyard.tif, format: tiles, max_error_m: 0.03, tile_px: 256}
vehicle: x500-sprayer
spawn: {x_m: -5.6, y_m: -18.0, yaw_deg: 90.0}
wind: {law: {type: constant, velocity_enu: [0.0, 0.0, 0.0]}}
rows: auto
canopy: {source: chm, base_m: 0.5}
"""
# truth: the autopilot flies on the simulator's state, so the gaps' bounds are the pump's alone (0.2-0.5 m at
# 1.5 m/s) and all three gaps of 1.2-2.0 m are judged; the field is 12.4 m wide: the spray reaches its edges
GAP_MISSION = """\
name: dose-gaps
vehicle: x500-sprayer
tank_fill_l: 1.0
truth: true
max_duration_s: 240
record_rate_hz: 50
dose: {drift_max: 0.5}
phases:
  - {type: takeoff, altitude_agl_m: 3.0}
  - {type: spray, rows: [0, 2], height_agl_m: 2.0, speed_mps: 1.5, lwa_dose_l: 40.0}
  - {type: rtl, return_altitude_agl_m: 4.0}
checks:
  - {name: completed, quantity: status, op: "==", bound: completed}
"""


def test_missing_vines_are_not_sprayed(tmp_path_factory: pytest.TempPathFactory) -> None:
    """The known-truth vineyard (tests/canopy_fixtures.py: missing vines of 1.6 m on row 0, 2.0 m and 1.2 m on row
    2) as a world with its canopy measured on the DSM: the built-in autopilot closes the sections over each gap
    (the pump delivers < 10 % of the rate beside it inside every gap, beyond its run-down), and doses the hedges."""
    from tests.canopy_fixtures import TRUTH, write_truth_dsm
    from vinecli.world import build_world

    d = tmp_path_factory.mktemp("gap-world")
    write_truth_dsm(d / "vineyard.tif")
    (d / "w.yaml").write_text(GAP_WORLD)
    world = build_world(d / "w.yaml", d / "world")
    (d / "m.yaml").write_text(GAP_MISSION)
    run = Path(run_mission(RunRequest(d / "m.yaml", world, d / "runs")).run_dir)
    s = _summary(run)
    assert s["passed"], [(c["name"], c["value"]) for c in s["checks"] if not c["passed"]]
    gaps = _as_applied(run)["gaps"]
    truth = sorted(b - a for r in (TRUTH.rows[0], TRUTH.rows[2]) for a, b in r.gaps)
    assert sorted(round(g["length_m"], 1) for g in gaps) == pytest.approx(truth, abs=0.15)
    assert all(g["gap"] and g["judged"] and not g["sprayed"] and g["interior_max_ratio"] < 0.1 for g in gaps)
    assert s["as_applied"]["in_band_fraction"] >= 0.9
    a = _as_applied(run)
    for b in a["bins"]:  # the pump's litres over the gaps are their ends' run-down only: < 25 % of the rate there
        presc, pump = np.array(b["prescribed_lpha"]), np.array(b["pump_lpha"])
        sprayed = presc[presc > 0].mean() if (presc > 0).any() else 0.0
        if (presc == 0).any():
            assert pump[presc == 0].mean() < 0.25 * sprayed
