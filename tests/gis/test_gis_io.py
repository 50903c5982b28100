"""GIS in and out: rows and polygons through GeoJSON, GeoPackage, Shapefile, KML and KMZ in WGS84 and UTM come
back to the same local coordinates within 1 cm; bad features are refused naming the layer and the feature."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pyogrio
import pyogrio.raw
import pytest
from shapely.geometry import LineString, Polygon

from vinecli.errors import InputError
from vinecli.geo import GeoOrigin
from vinecli.gis.georef import Georef
from vinecli.gis.read import read_features
from vinecli.gis.write import rows_features, write_features
from vinecli.rows.source import RowFrame

#: the sample DSM's frame: UTM 16N about the raster centre (worlds/sample, Hancock, Wisconsin)
FRAME = RowFrame("EPSG:32616", (296615.147, 4888216.6415))
ROWS = [[(-8.01 + 0.91 * i, -31.0), (-6.8 + 0.91 * i, 0.0), (-5.61 + 0.91 * i, 30.5)] for i in range(4)]
FENCE = [(-10.0, -34.1), (10.0, -34.1), (10.0, 34.1), (-10.0, 34.1)]


def _write(path: Path, geoms: list, crs: str | None, driver: str, props: dict | None = None) -> None:
    """A test file written with GDAL directly (as a grower's tools would), not with vinecli."""
    names = list(props or {})
    cols = [np.array(v, dtype=object) for v in (props or {}).values()]
    pyogrio.raw.write(path, np.array([g.wkb for g in geoms], dtype=object), cols, names, driver=driver, crs=crs,
                  geometry_type=geoms[0].geom_type)


@pytest.mark.parametrize("fmt,crs", [("geojson", "EPSG:4326"), ("gpkg", "EPSG:32616"), ("shp", "EPSG:32616"),
                                     ("gpkg", "EPSG:4326"), ("kml", "EPSG:4326"), ("kmz", "EPSG:4326")])
def test_rows_and_fence_round_trip_within_1_cm(tmp_path: Path, fmt: str, crs: str) -> None:
    g = Georef(FRAME)
    driver = {"geojson": "GeoJSON", "gpkg": "GPKG", "shp": "ESRI Shapefile", "kml": "KML", "kmz": "KML"}[fmt]
    rows = [LineString(g.to_crs(r, crs)) for r in ROWS]
    fence = [Polygon(g.to_crs(FENCE, crs))]
    ext = "kml" if fmt == "kmz" else fmt
    _write(tmp_path / f"rows.{ext}", rows, crs, driver)
    _write(tmp_path / f"fence.{ext}", fence, crs, driver)
    if fmt == "kmz":
        for n in ("rows", "fence"):
            with zipfile.ZipFile(tmp_path / f"{n}.kmz", "w") as z:
                z.write(tmp_path / f"{n}.kml", "doc.kml")
    got = read_features(tmp_path / f"rows.{fmt}", g, expect="lines")
    assert len(got) == 4
    for f, r in zip(got, ROWS, strict=True):
        assert np.max(np.abs(np.asarray(f.parts[0]) - np.asarray(r))) < 0.01
    poly = read_features(tmp_path / f"fence.{fmt}", g, expect="polygons")[0].parts[0]
    assert Polygon(poly).hausdorff_distance(Polygon(FENCE)) < 0.01  # a Shapefile turns the ring clockwise


@pytest.mark.parametrize("suffix", [".geojson", ".gpkg"])
def test_written_rows_are_rfc7946_and_read_back_within_1_cm(tmp_path: Path, suffix: str) -> None:
    """vinecli's own outputs: WGS84 longitude/latitude, no crs member; GeoPackage in EPSG:4326; both read back by
    GDAL into the same local metres (a DSM frame, and a flat world's topocentric frame)."""
    for g in (Georef(FRAME), Georef(origin=GeoOrigin(44.7, 8.03, 250.0))):
        out = write_features(tmp_path / f"rows{suffix}", rows_features(ROWS), g, layer="rows")
        if suffix == ".geojson":
            gj = json.loads(out.read_text())
            assert "crs" not in gj and gj["type"] == "FeatureCollection"
            lon, lat = gj["features"][0]["geometry"]["coordinates"][0]
            assert -180 <= lon <= 180 and -90 <= lat <= 90
        else:
            assert pyogrio.read_info(out, layer="rows")["crs"] == "EPSG:4326"
        back = read_features(out, g, expect="lines")
        err = max(float(np.max(np.abs(np.asarray(f.parts[0]) - np.asarray(r)))) for f, r in zip(back, ROWS, strict=True))
        assert err < 0.01
        assert [f.properties["index"] for f in back] == [0, 1, 2, 3]


def test_buffer_zone_grows_by_its_distance(tmp_path: Path) -> None:
    g = Georef(FRAME)
    zone = Polygon(g.to_lonlat([(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)]))
    _write(tmp_path / "nospray.geojson", [zone], "EPSG:4326", "GeoJSON", {"buffer_m": [2.0]})
    ring = read_features(tmp_path / "nospray.geojson", g, expect="polygons")[0].parts[0]
    assert Polygon(ring).area == pytest.approx(64.0, rel=1e-3)  # (4 + 2 x 2)^2, mitred corners


def test_bad_features_exit_2_naming_layer_and_feature(tmp_path: Path) -> None:
    g = Georef(FRAME)
    bowtie = Polygon(g.to_crs([(0.0, 0.0), (5.0, 5.0), (5.0, 0.0), (0.0, 5.0)], "EPSG:32616"))
    _write(tmp_path / "fence.gpkg", [bowtie], "EPSG:32616", "GPKG")
    with pytest.raises(InputError, match=r"layer 'fence' feature 1: invalid polygon \(Self-intersection") as e:
        read_features(tmp_path / "fence.gpkg", g, expect="polygons")
    assert e.value.exit_code == 2 and "fence.gpkg" in str(e.value)

    _write(tmp_path / "rows.gpkg", [LineString(g.to_crs(ROWS[0], "EPSG:32616"))], "EPSG:32616", "GPKG")
    with pytest.raises(InputError, match=r"layer 'rows' feature 1: LineString, expected Polygon"):
        read_features(tmp_path / "rows.gpkg", g, expect="polygons")
    with pytest.raises(InputError, match=r"layer 'rows' feature 1: row point .* outside the terrain"):
        read_features(tmp_path / "rows.gpkg", g, expect="lines", bounds=(-9.5, -34.0, 9.5, 30.0))

    _write(tmp_path / "noprj.shp", [LineString(g.to_crs(ROWS[0], "EPSG:32616"))], None, "ESRI Shapefile")
    with pytest.raises(InputError, match="layer 'noprj': no CRS"):
        read_features(tmp_path / "noprj.shp", g, expect="lines")

    (tmp_path / "empty.geojson").write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "id": 7, "properties": {}, "geometry": {"type": "LineString", "coordinates": []}}]}))
    with pytest.raises(InputError, match="feature 7: empty geometry"):
        read_features(tmp_path / "empty.geojson", g, expect="lines")
