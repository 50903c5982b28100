"""Attacks on the GIS inputs of a world: each bad file is exit 2 with one line naming the file
and the problem, and nothing is written."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import pytest
import yaml
from shapely.geometry import Polygon

from vinecli.errors import VinecliError

from .test_gis_world import FENCE_LOCAL, ROWS_LOCAL, grower_world, local, lonlat, utm, write_layer


def _build_fails(tmp: Path, gis: dict, match: str) -> VinecliError:
    from vinecli.world import build_world

    spec = grower_world(tmp)
    d = yaml.safe_load(spec.read_text())
    d["gis"] = gis
    spec.write_text(yaml.safe_dump(d))
    with pytest.raises(VinecliError, match=match) as exc:
        build_world(spec, tmp / "world")
    assert exc.value.exit_code == 2 and "\n" not in str(exc.value)
    assert not (tmp / "world").exists()
    return exc.value


def _geojson(path: Path, kind: str, coords: list) -> None:
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": kind, "coordinates": coords}}]}))


def test_projected_coordinates_in_a_geojson_are_a_wrong_crs(tmp_path: Path) -> None:
    """UTM metres written into a GeoJSON (which is WGS84 by definition): the file, the feature and the point named,
    the likely cause said (before: 'row point (inf, inf)' or a fence '-inf m' from the spawn)."""
    _geojson(tmp_path / "utm_rows.geojson", "LineString", [list(p) for p in utm(ROWS_LOCAL[0])])
    err = _build_fails(tmp_path, {"rows": {"path": "utm_rows.geojson"}}, r"feature 0: point \(424[\d.]+, 495[\d.]+\) in "
                       r"EPSG:4326 is not near the world \(not a valid position\): wrong CRS\? \(GeoJSON and KML hold")
    assert "utm_rows.geojson" in str(err)
    ring = [list(p) for p in utm(FENCE_LOCAL)]
    _geojson(tmp_path / "utm_fence.geojson", "Polygon", [ring + [ring[0]]])
    _build_fails(tmp_path, {"fence": {"path": "utm_fence.geojson"}}, "utm_fence.geojson.*wrong CRS")


def test_huge_coordinates_are_refused(tmp_path: Path) -> None:
    """A zone 1e300 wide (built silently before, cutting the rows with infinities)."""
    _geojson(tmp_path / "huge.geojson", "Polygon", [[[0, 0], [1e300, 0], [1e300, 1e300], [0, 0]]])
    _build_fails(tmp_path, {"rows": {"path": "rows.gpkg"}, "no_spray": [{"path": "huge.geojson"}]},
                 "huge.geojson.*wrong CRS")
    _geojson(tmp_path / "far.geojson", "LineString", [[8.04, 44.7], [10.5, 44.7]])  # valid WGS84, ends 195 km away
    _build_fails(tmp_path, {"rows": {"path": "far.geojson"}}, r"far.geojson.*\(195 km away\): wrong CRS")


def test_empty_layers_and_broken_kmz_are_refused(tmp_path: Path) -> None:
    (tmp_path / "empty.geojson").write_text(json.dumps({"type": "FeatureCollection", "features": []}))
    _build_fails(tmp_path, {"rows": {"path": "empty.geojson"}}, "empty.geojson: layer 'empty': no features")
    with zipfile.ZipFile(tmp_path / "nokml.kmz", "w") as z:
        z.writestr("readme.txt", "no KML in here")
    _build_fails(tmp_path, {"fence": {"path": "nokml.kmz"}}, "nokml.kmz: cannot read GIS file")
    (tmp_path / "garbage.kmz").write_bytes(b"not a zip")
    _build_fails(tmp_path, {"fence": {"path": "garbage.kmz"}}, "garbage.kmz: cannot read GIS file")
    _build_fails(tmp_path, {"rows": {"path": "rows.gpkg", "layer": "nope"}}, "rows.gpkg: cannot read GIS file")


def test_a_fence_that_excludes_the_spawn_is_refused(tmp_path: Path) -> None:
    far = [local(5, -6), local(17, -6), local(17, 6), local(5, 6)]
    write_layer(tmp_path / "far_fence.kml", [Polygon(lonlat(far))], "EPSG:4326", "KML")
    _build_fails(tmp_path, {"fence": {"path": "far_fence.kml"}}, "spawn .* is outside the geofence")


def test_no_spray_zones_that_cover_every_row_are_refused(tmp_path: Path) -> None:
    """A zone over the whole block: nothing would be sprayed (built with 0 rows before)."""
    big = [local(-30, -30), local(30, -30), local(30, 30), local(-30, 30)]
    write_layer(tmp_path / "bigzone.geojson", [Polygon(lonlat(big))], "EPSG:4326", "GeoJSON")
    _build_fails(tmp_path, {"rows": {"path": "rows.gpkg"}, "no_spray": [{"path": "bigzone.geojson", "buffer_m": 2}]},
                 "bigzone.geojson: the 1 no-spray zones .* cover all 3 rows: nothing would be sprayed")


def test_outputs_aimed_at_the_gis_inputs_are_refused(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from vinecli.cli.app import app

    spec = grower_world(tmp_path)
    before = (tmp_path / "rows.gpkg").read_bytes()
    for out in ("rows.gpkg", "fence.kml"):
        r = CliRunner().invoke(app, ["world", "build", str(spec), "--out", str(tmp_path / out)])
        assert r.exit_code == 2 and "an input (nothing written)" in r.output, r.output
    assert (tmp_path / "rows.gpkg").read_bytes() == before
