"""``vinecli terrain convert`` / ``terrain info`` through the CLI: outputs, and one-line errors for bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from dsm_fixtures import TEST_DATA, plane_dsm, smooth, write_dsm
from rasterio.transform import from_origin
from typer.testing import CliRunner

from vinecli.cli.app import app


def run(*args: str):
    return CliRunner().invoke(app, ["terrain", *args])


def error_lines(result) -> list[str]:
    return [ln for ln in result.stderr.splitlines() if ln.startswith("vinecli: error:")]


def test_convert_heightmap_cli(tmp_path: Path) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=257, h=200)
    out = tmp_path / "hm"
    r = run("convert", str(src), "--to", "heightmap", "--size", "129", "--method", "max", "--out", str(out))
    assert r.exit_code == 0, r.stderr
    assert "129 x 129 vertices" in r.stdout and "geodetic origin" in r.stdout
    m = json.loads((out / "heightmap.json").read_text())
    assert m["size_px"] == 129 and m["resampling"] == "max"
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["command"] == "terrain convert --to heightmap" and manifest["parameters"]["size"] == 129
    assert manifest["inputs"][0]["sha256"]


def test_convert_heightmap_cli_window_bbox_fill(tmp_path: Path) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=200, h=150)
    r = run("convert", str(src), "--to", "heightmap", "--size", "33", "--window", "10,20,65,65", "--out",
            str(tmp_path / "w"))
    assert r.exit_code == 0, r.stderr
    assert json.loads((tmp_path / "w" / "heightmap.json").read_text())["crop"]["window_px"] == [10, 20, 65, 65]
    r = run("convert", str(src), "--to", "heightmap", "--size", "33", "--bbox", "500020,4999900,500084,4999964",
            "--fill", "nearest", "--out", str(tmp_path / "b"))
    assert r.exit_code == 0, r.stderr
    assert json.loads((tmp_path / "b" / "heightmap.json").read_text())["bounds"] == [500020, 4999900, 500084,
                                                                                      4999964]


def test_convert_tiles_cli(tmp_path: Path) -> None:
    z = smooth(129, 161, seed=4).astype(np.float32)
    src = write_dsm(tmp_path / "s.tif", z, transform=from_origin(0, 129, 1, 1), crs="EPSG:32633")
    out = tmp_path / "tiles"
    r = run("convert", str(src), "--to", "tiles", "--max-error", "0.05", "--tile-px", "64", "--format", "stl",
            "--out", str(out))
    assert r.exit_code == 0, r.stderr
    assert "vertical error" in r.stdout
    m = json.loads((out / "tiles.json").read_text())
    assert m["mesh_format"] == "stl" and m["totals"]["max_error_m"] <= 0.05
    assert len(list((out / "tiles").glob("*.stl"))) == m["totals"]["tiles"] == 6


def test_overwrite_replaces_output(tmp_path: Path) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=65, h=65)
    out = tmp_path / "hm"
    assert run("convert", str(src), "--to", "heightmap", "--size", "33", "--out", str(out)).exit_code == 0
    r = run("convert", str(src), "--to", "heightmap", "--size", "65", "--out", str(out))
    assert r.exit_code == 2 and "not empty" in r.stderr
    r = run("convert", str(src), "--to", "heightmap", "--size", "65", "--out", str(out), "--overwrite")
    assert r.exit_code == 0
    assert json.loads((out / "heightmap.json").read_text())["size_px"] == 65


# ---------------------------------------------------------------- bad input: one line, exit 2, nothing written
def _text_tif(d: Path) -> tuple[Path, list[str], str]:
    p = d / "notes.tif"
    p.write_text("this is not a raster\n")
    return p, [], "not a readable GeoTIFF"


def _truncated(d: Path) -> tuple[Path, list[str], str]:
    src = write_dsm(d / "full.tif", smooth(300, 300).astype(np.float32), transform=from_origin(0, 300, 1, 1),
                    crs="EPSG:32633")
    data = src.read_bytes()
    p = d / "truncated.tif"
    p.write_bytes(data[: len(data) // 2])
    return p, [], "truncated or corrupt"


def _multiband(d: Path) -> tuple[Path, list[str], str]:
    rgb = np.stack([smooth(40, 40, seed=i) for i in range(3)]).astype(np.uint8)
    return write_dsm(d / "rgb.tif", rgb, transform=from_origin(0, 40, 1, 1), crs="EPSG:32633"), [], "3 bands"


def _all_nodata(d: Path) -> tuple[Path, list[str], str]:
    z = np.full((30, 30), np.nan, np.float32)
    return (write_dsm(d / "holes.tif", z, transform=from_origin(0, 30, 1, 1), crs="EPSG:32633", nodata=np.nan),
            [], "nodata")


def _window_outside(d: Path) -> tuple[Path, list[str], str]:
    return plane_dsm(d / "p.tif", w=50, h=40), ["--window", "30,0,30,30"], "outside the raster"


def _bad_size(d: Path) -> tuple[Path, list[str], str]:
    return plane_dsm(d / "p.tif", w=50, h=40), ["--size", "100"], "2^n+1"


def _huge_size(d: Path) -> tuple[Path, list[str], str]:
    return plane_dsm(d / "p.tif", w=50, h=40), ["--size", "2049"], "break silently"


def _unknown_ext(d: Path) -> tuple[Path, list[str], str]:
    p = d / "dem.asc"
    p.write_text("ncols 2\n")
    return p, [], "unknown extension"


def _missing(d: Path) -> tuple[Path, list[str], str]:
    return d / "nope.tif", [], "not found"


def _bad_window_text(d: Path) -> tuple[Path, list[str], str]:
    return plane_dsm(d / "p.tif", w=50, h=40), ["--window", "1,2,three,4"], "comma-separated integers"


BAD = [_text_tif, _truncated, _multiband, _all_nodata, _window_outside, _bad_size, _huge_size, _unknown_ext,
       _missing, _bad_window_text]


def _leftovers(d: Path) -> list[str]:
    return sorted(p.name for p in d.iterdir() if p.name.startswith(".out") or p.name == "out")


FILE_BAD = [_text_tif, _truncated, _multiband, _all_nodata, _unknown_ext, _missing]
CASES = [(m, "heightmap") for m in BAD] + [(m, "tiles") for m in FILE_BAD]


@pytest.mark.parametrize(("make", "to"), CASES, ids=[f"{to}-{m.__name__.strip('_')}" for m, to in CASES])
def test_bad_input_one_line_exit_2_nothing_written(tmp_path: Path, make, to: str) -> None:
    src, extra, words = make(tmp_path)
    out = tmp_path / "out"
    r = run("convert", str(src), "--to", to, "--out", str(out), *extra)
    assert r.exit_code == 2, (r.stdout, r.stderr)
    lines = error_lines(r)
    assert len(lines) == 1 and "Traceback" not in r.stderr
    assert str(src) in lines[0] and words in lines[0], lines[0]
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("to", ["heightmap", "tiles"])
def test_non_empty_output_dir(tmp_path: Path, to: str) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=40, h=40)
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    r = run("convert", str(src), "--to", to, "--out", str(out))
    assert r.exit_code == 2 and len(error_lines(r)) == 1
    assert str(out) in error_lines(r)[0] and "not empty" in r.stderr
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".out")] == []


@pytest.mark.parametrize("where", ["file-parent", "proc"])
def test_unwritable_output_dir(tmp_path: Path, where: str) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=40, h=40)
    if where == "file-parent":
        (tmp_path / "afile").write_text("x")
        out = tmp_path / "afile" / "out"
    else:
        out = Path("/proc/vinecli-test-no-such-dir/out")  # not writable even for root
    r = run("convert", str(src), "--to", "heightmap", "--out", str(out))
    assert r.exit_code == 2, r.stderr
    lines = error_lines(r)
    assert len(lines) == 1 and str(out) in lines[0] and "not writable" in lines[0]
    assert not out.exists()


@pytest.mark.parametrize(("args", "words"), [
    (["--to", "tiles", "--size", "65"], "--size apply to --to heightmap only"),
    (["--to", "tiles", "--method", "max"], "--method apply to --to heightmap only"),
    (["--to", "heightmap", "--max-error", "0.1"], "--max-error apply to --to tiles only"),
    (["--to", "mesh"], "choose heightmap or tiles"),
    (["--to", "heightmap", "--method", "lanczos"], "--method 'lanczos'"),
    (["--to", "heightmap", "--fill", "zero"], "--fill 'zero'"),
    (["--to", "heightmap", "--window", "0,0,10,10", "--bbox", "0,0,1,1"], "mutually exclusive"),
    (["--to", "heightmap", "--z-unit", "yard"], "unknown vertical unit"),
])
def test_bad_options(tmp_path: Path, args: list[str], words: str) -> None:
    src = plane_dsm(tmp_path / "p.tif", w=40, h=40)
    r = run("convert", str(src), "--out", str(tmp_path / "out"), *args)
    assert r.exit_code == 2
    lines = error_lines(r)
    assert len(lines) == 1 and words in lines[0] and str(src) in lines[0], r.stderr
    assert _leftovers(tmp_path) == []


def test_real_geotiff_with_odd_layout(tmp_path: Path) -> None:
    """The committed 3 arc-second int16 DEM (tiled 16x16, EPSG:4326) converts through the CLI."""
    src = TEST_DATA / "pysheds_dem_3arcsec_epsg4326_int16.tif"
    r = run("convert", str(src), "--to", "heightmap", "--size", "257", "--out", str(tmp_path / "hm"))
    assert r.exit_code == 0, r.stderr
    m = json.loads((tmp_path / "hm" / "heightmap.json").read_text())
    assert m["crs"] == "EPSG:4326" and 50 < m["spacing_m"] < 120
    with rasterio.open(tmp_path / "hm" / "heightmap.tif") as ds:
        assert ds.crs.is_projected and 147 <= ds.read(1).min() and ds.read(1).max() <= 298
