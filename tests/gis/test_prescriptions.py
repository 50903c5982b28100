"""Prescription maps (vinecli.gis.prescription, vinecli.gis.isoxml_read) over the known-truth vineyard, in CRSs
other than its DSM's (UTM 32N): every format gives the zone rates along the rows; segment rates are cut at the
zone edges; ``plan rows --prescription`` writes them; every bad map is refused with exit 2, one line naming the
file, the inputs byte-identical and nothing written."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tests.canopy_fixtures import write_truth_dsm
from tests.prescription_fixtures import write_rate_raster, write_taskdata, write_zones, zone_rate
from vinecli.cli.app import app
from vinecli.gis.georef import Georef
from vinecli.gis.prescription import read_prescription
from vinecli.gis.rate_map import RateMap
from vinecli.rows.dsm_canopy import DsmCanopy, measure_dsm_canopy
from vinecli.rows.segment_rates import SegmentRates, segment_rates

runner = CliRunner()


@pytest.fixture(scope="module")
def field(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, DsmCanopy, Georef]:
    d = tmp_path_factory.mktemp("field")
    c = measure_dsm_canopy(write_truth_dsm(d / "vineyard.tif"), base_m=0.5)
    return d / "vineyard.tif", c, Georef(c.rows.frame, c.rows.origin)


MAPS = {
    "gpkg-3857": lambda d, g: write_zones(d / "zones.gpkg", g, "EPSG:3857"),
    "shp-4326": lambda d, g: write_zones(d / "zones.shp", g, "EPSG:4326"),
    "geojson": lambda d, g: write_zones(d / "zones.geojson", g, "EPSG:4326"),
    "gpkg-utm33": lambda d, g: write_zones(d / "zones33.gpkg", g, "EPSG:32633"),
    "tif-3857": lambda d, g: write_rate_raster(d / "rates.tif", g),
    "isoxml-zones": lambda d, g: write_taskdata(d / "tz", g, "zones"),
    "isoxml-grid1": lambda d, g: write_taskdata(d / "g1", g, "grid1"),
    "isoxml-grid2": lambda d, g: write_taskdata(d / "g2", g, "grid2").parent,  # the folder works too
}


@pytest.mark.parametrize("kind", sorted(MAPS))
def test_each_format_gives_the_zone_rates(kind: str, field: tuple, tmp_path: Path) -> None:
    _, c, g = field
    path = MAPS[kind](tmp_path, g)
    m = read_prescription(path, g, c.rows.detection.rows, column="rate")
    ys = np.linspace(-14.0, 14.0, 57)
    ys = ys[np.min(np.abs(ys[:, None] - np.array([-5.0, 5.0])[None, :]), axis=1) > 1.1]  # clear of the edges
    for x in (-3.75, 1.25):
        np.testing.assert_allclose(m.rates(np.full(ys.size, x), ys), [zone_rate(y) for y in ys], rtol=1e-6)
    rates = segment_rates(c.segments, rate_map=m.rates, prescription=m.summary(), rows=c.rows.detection.rows)
    _check_cut_at_zone_edges(rates, m)


def _check_cut_at_zone_edges(rates: SegmentRates, m: RateMap) -> None:
    """Each segment has one rate, its zone's (gaps 0), and the cuts fall within a grid cell / 0.3 m of the edges."""
    for s in rates.segments:
        mid_y = 0.5 * (s.start_enu[1] + s.end_enu[1])
        if s.gap:
            assert s.rate_lpha == 0.0
        elif min(abs(mid_y + 5.0), abs(mid_y - 5.0)) > 1.2:
            assert s.rate_lpha == pytest.approx(zone_rate(mid_y), rel=1e-6), s
    assert {round(s.rate_lpha) for s in rates.segments if not s.gap} == {150, 200, 250}
    summ = rates.summary()
    assert summ["gap_length_m"] > 4.0 and summ["saving_l"] > 0


def _digest(paths: list[Path]) -> dict[Path, str]:
    files = [q for p in paths for q in ([p] if p.is_file() else sorted(p.rglob("*")))]
    return {q: hashlib.sha256(q.read_bytes()).hexdigest() for q in files if q.is_file()}


def _plan(dsm: Path, out: Path, *args: str):
    return runner.invoke(app, ["plan", "rows", str(dsm), "--out", str(out), *args])


def test_plan_rows_with_a_prescription(field: tuple, tmp_path: Path) -> None:
    dsm, _, g = field
    path = write_zones(tmp_path / "zones.gpkg", g, "EPSG:3857")
    res = _plan(dsm, tmp_path / "p.plan", "--prescription", str(path), "--rate-column", "rate")
    assert res.exit_code == 0, res.output
    rates = SegmentRates.read(tmp_path / "p.rates.json")
    assert {round(s.rate_lpha) for s in rates.segments if not s.gap} == {150, 200, 250}
    assert rates.prescription is not None and rates.prescription["kind"] == "zones"
    assert (tmp_path / "p.rates.geojson").is_file()


def _bad(kind: str, d: Path, g: Georef) -> tuple[Path, list[str], str]:
    """A bad map of class ``kind``: (path, extra options, what the error says)."""
    if kind == "no overlap":
        far = Georef(g.frame, g.origin)
        p = write_zones(d / "far.gpkg", Georef(far.frame.__class__(far.frame.crs, (far.frame.centre[0] + 5000,
                                                                                   far.frame.centre[1]), far.frame.scale),
                                                  g.origin), "EPSG:3857")
        return p, ["--rate-column", "rate"], "no overlap with the field"
    if kind == "missing column":
        return write_zones(d / "z.gpkg", g, "EPSG:3857"), ["--rate-column", "dose"], "no rate column 'dose'"
    if kind == "non-numeric":
        return (write_zones(d / "z.gpkg", g, "EPSG:3857", rates=["150", "lots", "250"]), ["--rate-column", "rate"],
                "'lots' is not a number")
    if kind == "negative":
        return write_zones(d / "z.gpkg", g, "EPSG:3857", rates=[150.0, -20.0, 250.0]), ["--rate-column", "rate"], \
            "negative rate"
    if kind == "absurd":
        return write_zones(d / "z.gpkg", g, "EPSG:3857", rates=[150.0, 2e6, 250.0]), ["--rate-column", "rate"], \
            "absurd rate"
    if kind == "absurd raster":
        return write_rate_raster(d / "r.tif", g, scale=1e3), [], "absurd rate"
    if kind == "broken xml":
        p = write_taskdata(d / "td", g, "zones")
        p.write_bytes(p.read_bytes()[:-40])
        return p, [], "broken ISO-XML"
    if kind == "unknown units (ddi)":
        return write_taskdata(d / "td", g, "grid1", ddi=6), [], "unknown units: DDI 6"
    if kind == "unknown units (option)":
        return write_zones(d / "z.gpkg", g, "EPSG:3857"), ["--rate-column", "rate", "--rate-units", "kg/ha"], \
            "unknown rate units"
    if kind == "isoxml rate in the wrong unit":
        return write_taskdata(d / "td", g, "grid2", rate_scale=1e-4), [], "absurd rate"
    if kind == "no default outside":
        p = write_zones(d / "z.gpkg", g, "EPSG:3857")
        import pyogrio

        df_geoms = pyogrio.raw.read(p)
        meta, _, geoms, fields = df_geoms
        pyogrio.raw.write(d / "two.gpkg", geoms[:2], [f[:2] for f in fields], list(meta["fields"]), driver="GPKG",
                          crs=meta["crs"], geometry_type="Polygon")
        return d / "two.gpkg", ["--rate-column", "rate"], "give a default rate"
    raise AssertionError(kind)


BAD = ["no overlap", "missing column", "non-numeric", "negative", "absurd", "absurd raster", "broken xml",
       "unknown units (ddi)", "unknown units (option)", "isoxml rate in the wrong unit", "no default outside"]


@pytest.mark.parametrize("kind", BAD)
def test_bad_map_refused(kind: str, field: tuple, tmp_path: Path) -> None:
    dsm, _, g = field
    maps = tmp_path / "maps"
    maps.mkdir()
    path, extra, says = _bad(kind, maps, g)
    before = _digest([maps, dsm])
    out = tmp_path / "out"
    out.mkdir()
    res = _plan(dsm, out / "p.plan", "--prescription", str(path), *extra)
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    err = [ln for ln in lines if ln.startswith("vinecli: error")]
    assert len(err) == 1 and says in err[0], res.output
    assert path.name in err[0] or path.parent.name in err[0]
    assert "Traceback" not in res.output
    assert _digest([maps, dsm]) == before
    assert list(out.iterdir()) == []


def test_zone_rates_split_a_canopy_segment(field: tuple) -> None:
    """A segment across a zone edge becomes two, each at its zone's rate, meeting within 0.2 m of the edge (rows 0,
    1 and 3: row 2 has a gap there)."""
    _, c, g = field
    rates = segment_rates(c.segments, rate_map=lambda x, y: np.where(y < 0.3, 100.0, 300.0), rows=c.rows.detection.rows)
    for row in (0, 1, 3):
        segs = [s for s in rates.for_row(row) if not s.gap]
        edge = [s for s, t in zip(segs[:-1], segs[1:], strict=True) if s.rate_lpha != t.rate_lpha]
        assert len(edge) == 1
        assert edge[0].end_enu[1] == pytest.approx(0.3, abs=0.2)


def test_a_zone_with_a_hole(field: tuple, tmp_path: Path) -> None:
    """A zone's hole (an island of the field it does not cover) gets the default rate, and a zone inside the hole
    its own: holes are read from the file (GeoPackage in Web Mercator) and survive the reprojection."""
    import pyogrio.raw
    from shapely.geometry import Polygon

    _, c, g = field
    outer = g.to_crs([(-8.0, -16.0), (8.0, -16.0), (8.0, 16.0), (-8.0, 16.0)], "EPSG:3857")
    hole = g.to_crs([(-7.0, -4.0), (7.0, -4.0), (7.0, 4.0), (-7.0, 4.0)], "EPSG:3857")
    island = g.to_crs([(-6.0, -2.0), (6.0, -2.0), (6.0, 2.0), (-6.0, 2.0)], "EPSG:3857")
    path = tmp_path / "holed.gpkg"
    assert Polygon(outer, [hole]).is_valid
    geoms = np.array([Polygon(outer, [hole]).wkb, Polygon(island).wkb], dtype=object)
    pyogrio.raw.write(path, geoms, [np.array([120.0, 300.0])], ["rate"], driver="GPKG", crs="EPSG:3857",
                      geometry_type="Polygon")
    m = read_prescription(path, g, c.rows.detection.rows, column="rate", default_lpha=50.0)
    y = np.array([-10.0, -3.0, 0.0, 3.0, 10.0])
    assert m.rates(np.zeros(5), y).tolist() == [120.0, 50.0, 300.0, 50.0, 120.0]
