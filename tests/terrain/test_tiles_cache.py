"""The conversion cache of mesh tiles (vinecli/terrain/tiles_cache.py): ``world build`` takes the tiles
``terrain convert --to tiles`` made of the same DSM with the same parameters, and what it writes is what meshing
again writes, byte for byte."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from sim_helpers import world_yaml

from vinecli.terrain.tiles import convert_to_tiles
from vinecli.world import build_world


def _files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _cache_note(folder: Path) -> dict[str, object]:
    return json.loads((folder / "manifest.json").read_text())["tiles_cache"]


def _without_timing(tiles_json: bytes) -> dict[str, object]:
    doc = json.loads(tiles_json)
    doc.pop("seconds")  # how long the meshing took
    return doc


def test_world_build_takes_the_converted_tiles_and_writes_what_meshing_writes(
        bumpy_dsm: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VINECLI_TERRAIN_CACHE_DIR", str(tmp_path / "cache"))
    convert_to_tiles(bumpy_dsm, tmp_path / "converted", max_error=0.02, tile_px=64)
    assert _cache_note(tmp_path / "converted")["hit"] is False
    again = convert_to_tiles(bumpy_dsm, tmp_path / "again", max_error=0.02, tile_px=64)
    assert _cache_note(tmp_path / "again")["hit"] is True and len(again.tiles) == 16
    converted, copied = _files(tmp_path / "converted"), _files(tmp_path / "again")
    assert converted.keys() == copied.keys()
    for name in converted:
        if name != "manifest.json":  # its timings and output digests
            assert copied[name] == converted[name], name

    spec = world_yaml(tmp_path, {"type": "dsm", "path": str(bumpy_dsm), "format": "tiles", "max_error_m": 0.02,
                                 "tile_px": 64}, spawn={"x_m": 1.0, "y_m": -2.0})
    build_world(spec, tmp_path / "cached")
    assert _cache_note(tmp_path / "cached" / "terrain")["hit"] is True
    monkeypatch.setenv("VINECLI_TERRAIN_CACHE_DIR", "off")
    build_world(spec, tmp_path / "meshed")
    assert "tiles_cache" not in json.loads((tmp_path / "meshed" / "terrain" / "manifest.json").read_text())
    cached, meshed = _files(tmp_path / "cached"), _files(tmp_path / "meshed")
    assert cached.keys() == meshed.keys()
    for name in meshed:
        if name.endswith(".obj") or name.endswith(".urdf") or name.endswith(".sdf") or name == "world.json":
            assert cached[name] == meshed[name], name
    assert _without_timing(cached["terrain/tiles.json"]) == _without_timing(meshed["terrain/tiles.json"])
    with np.load(tmp_path / "cached" / "terrain" / "grid.npz") as a, \
            np.load(tmp_path / "meshed" / "terrain" / "grid.npz") as b:
        assert a.files == b.files
        for k in a.files:
            np.testing.assert_array_equal(a[k], b[k])


def test_another_dsm_or_parameter_is_another_entry(bumpy_dsm: Path, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VINECLI_TERRAIN_CACHE_DIR", str(tmp_path / "cache"))
    convert_to_tiles(bumpy_dsm, tmp_path / "a", max_error=0.02, tile_px=64)
    convert_to_tiles(bumpy_dsm, tmp_path / "b", max_error=0.03, tile_px=64)
    assert _cache_note(tmp_path / "b")["hit"] is False
    dsm = tmp_path / "copy.tif"
    data = bytearray(bumpy_dsm.read_bytes())
    shutil.copyfile(bumpy_dsm, dsm)
    import rasterio

    with rasterio.open(dsm, "r+") as ds:  # one height changed by 1 mm
        z = ds.read(1)
        z[100, 100] += 0.001
        ds.write(z, 1)
    assert dsm.read_bytes() != bytes(data)
    convert_to_tiles(dsm, tmp_path / "c", max_error=0.02, tile_px=64)
    assert _cache_note(tmp_path / "c")["hit"] is False
    keys = {_cache_note(tmp_path / n)["key"] for n in "abc"}
    assert len(keys) == 3 and len(list((tmp_path / "cache").glob("*/*"))) == 3


def test_the_cache_is_off_with_vinecli_cache_dir_off(bumpy_dsm: Path, tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("VINECLI_TERRAIN_CACHE_DIR", raising=False)
    monkeypatch.setenv("VINECLI_CACHE_DIR", "off")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    convert_to_tiles(bumpy_dsm, tmp_path / "a", max_error=0.02, tile_px=64)
    assert not (tmp_path / "xdg").exists()
    monkeypatch.delenv("VINECLI_CACHE_DIR")
    convert_to_tiles(bumpy_dsm, tmp_path / "b", max_error=0.02, tile_px=64)
    assert len(list((tmp_path / "xdg" / "vinecli" / "terrain").glob("*/*"))) == 1
