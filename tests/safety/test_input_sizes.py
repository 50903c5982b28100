"""Sizes no real field reaches, given the way the earlier size tests did not try, end early with one line.

* a mission YAML of one row of 10^6 vertices written inline (27 MB; the GIS route is in test_hostile_inputs.py):
  libyaml's node graph took 1.8 GB and minutes before the values were counted; the file's size is refused first;
* a DSM of more pixels than :data:`vinecli.specs.limits.MAX_DSM_PX` (a compressed GeoTIFF of 70,000 x 70,000
  empty pixels is 0.6 MB): every DSM reader refused or read it for minutes (``plan rows`` ended exit 3 after 78 s
  and 1.3 GB); now ``terrain info``, ``terrain convert`` and ``plan rows`` refuse it at open, naming the limit;
* a DSM with no valid pixel is bad input for ``plan rows`` (it was an internal ZeroDivisionError, exit 3);
* ``terrain info`` streams a 300,000 x 300 px raster in windows of about 4 Mpx (full-width strips of one block
  row held 77 Mpx at once).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from attack_kit import cli, error_line
from memguard import run_child

CLI = "import sys; from vinecli.cli.app import app; sys.argv = ['vinecli'] + sys.argv[1:]; app()"


def _geotiff(path: Path, width: int, height: int, data: np.ndarray | None = None) -> Path:
    import rasterio
    from rasterio.transform import from_origin

    with rasterio.open(path, "w", driver="GTiff", width=width, height=height, count=1, dtype="float32",
                       crs="EPSG:32616", transform=from_origin(296600.0, 4888200.0, 0.01, 0.01), tiled=True,
                       compress="deflate", sparse_ok=True, nodata=-9999.0) as ds:
        if data is not None:
            ds.write(data, 1)
    return path


def test_an_inline_row_of_a_million_vertices_is_refused_by_the_file_size(flat_world_dir: Path, tmp_path: Path
                                                                          ) -> None:
    # written as flow-style YAML text (PyYAML's representer takes most of a minute for a million vertices)
    row = ", ".join(f"[{round(float(x), 6)!r}, 0.0]" for x in np.linspace(-5.0, 5.0, 1_000_000))
    m = tmp_path / "big.yaml"
    m.write_text("{name: big, vehicle: x500-sprayer, max_duration_s: 60, phases: [{type: takeoff, altitude_agl_m: 2.5}, "
                 f"{{type: spray, rows: [[{row}]], height_agl_m: 2.0, speed_mps: 3.0, rate_lpha: 60.0}}]}}\n")
    assert m.stat().st_size > 16 << 20
    r = run_child([sys.executable, "-c", CLI, "run", "mission", str(m), "--world", str(flat_world_dir), "--out",
                   str(tmp_path / "runs")], timeout=600)
    assert r.returncode == 2, r.stderr[-2000:]
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "big.yaml" in lines[0] and "at most 16 MB" in lines[0], lines
    assert r.peak_rss_mb < 600, r.peak_rss_mb  # was 1.8 GB
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("command", [["terrain", "info"], ["terrain", "convert", "--to", "heightmap", "--out", "OUT"],
                                     ["plan", "rows", "--out", "OUT.plan"]])
def test_a_dsm_over_the_pixel_limit_is_refused_at_open(tmp_path: Path, command: list[str]) -> None:
    tif = _geotiff(tmp_path / "big.tif", 70_000, 70_000)  # 4.9 Gpx of nothing, 0.6 MB
    args = [str(tmp_path / a) if a.startswith("OUT") else a for a in command]
    r = run_child([sys.executable, "-c", CLI, *args[:2], str(tif), *args[2:]], timeout=600)
    assert r.returncode == 2, r.stderr[-2000:]
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "big.tif" in lines[0] and "70,000x70,000 px (4.9 Gpx): at most 4 Gpx" in lines[0]
    assert r.peak_rss_mb < 400, r.peak_rss_mb
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.tif"]


def test_a_dsm_without_a_valid_pixel_is_bad_input_for_plan_rows(tmp_path: Path) -> None:
    tif = _geotiff(tmp_path / "empty.tif", 3000, 3000)
    r = cli("plan", "rows", tif, "--out", tmp_path / "e.plan")
    assert r.exit_code == 2 and "no valid heights" in error_line(r), r.output


def test_terrain_info_streams_a_wide_raster_in_bounded_windows(tmp_path: Path) -> None:
    w, h = 300_000, 300
    z = np.full((h, w), 100.0, "float32") + np.arange(w, dtype="float32")[None, :] * np.float32(1e-4)
    z[7, 123_456] = 250.0
    tif = _geotiff(tmp_path / "wide.tif", w, h, z)
    del z
    r = run_child([sys.executable, "-c", "import json, sys\nfrom vinecli.terrain.raster import gdal_env, "
                   "inspect_dsm, open_raster, scan_heights\nwith gdal_env(), open_raster(sys.argv[1]) as src:\n"
                   "    print(json.dumps(scan_heights(src, inspect_dsm(src))))", str(tif)], timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    import json

    stats = json.loads(r.stdout)
    assert stats["valid"] == w * h and stats["z_max"] == 250.0 and stats["z_min"] == 100.0
    assert r.peak_rss_mb < 300, r.peak_rss_mb  # full-width strips: 256 x 300,000 px (77 Mpx, 307 MB of float32) at once
