"""Canopy segments measured on a DSM of known canopy (tests/canopy_fixtures.py): tops, widths and volumes within
5 %, the missing vines found as gaps, LWA and TRV from the measures; a given canopy as uniform segments."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.canopy_fixtures import TRUTH, write_truth_dsm
from vinecli.rows.canopy_segments import CanopySegments, hedge_segments
from vinecli.rows.dose_units import lwa_m2_per_ha, trv_m3_per_ha
from vinecli.rows.dsm_canopy import DsmCanopy, measure_dsm_canopy
from vinecli.spray.canopy import Hedge

BASE_M = 0.5


@pytest.fixture(scope="module")
def measured(tmp_path_factory: pytest.TempPathFactory) -> DsmCanopy:
    path = write_truth_dsm(tmp_path_factory.mktemp("truth") / "truth.tif")
    return measure_dsm_canopy(path, base_m=BASE_M, segment_m=2.0)


def test_every_row_found(measured: DsmCanopy) -> None:
    assert len(measured.rows.detection.rows) == len(TRUTH.rows)
    assert measured.segments.spacing_m == pytest.approx(TRUTH.spacing_m, rel=0.02)


def test_segments_within_5_percent(measured: DsmCanopy) -> None:
    for i, truth in enumerate(TRUTH.rows):
        canopy = [g for g in measured.segments.for_row(i) if not g.gap]
        assert canopy, f"row {i}: no canopy"
        wall = truth.top_m - BASE_M
        for g in canopy:
            assert g.top_m == pytest.approx(truth.top_m, rel=0.05), (i, g)
            assert g.wall_height_m == pytest.approx(wall, rel=0.05), (i, g)
            assert g.width_m == pytest.approx(truth.width_m, rel=0.05), (i, g)
            assert g.volume_m3 == pytest.approx(truth.width_m * wall * g.length_m * g.cover, rel=0.06), (i, g)
            assert g.lwa_m2pha() == pytest.approx(lwa_m2_per_ha(TRUTH.spacing_m, wall), rel=0.05)
            assert g.trv_m3pha() == pytest.approx(trv_m3_per_ha(TRUTH.spacing_m, wall, truth.width_m), rel=0.08)
            assert 1.0 <= g.length_m <= 3.0


def test_gaps_found_where_the_vines_are_missing(measured: DsmCanopy) -> None:
    """Each missing stretch is one gap segment whose ends lie within 0.15 m of the truth. The local frame runs
    along the CRS axes about the raster centre, so a truth row's along position a is at y = a - length / 2."""
    for i, truth in enumerate(TRUTH.rows):
        gaps = sorted((sorted((g.start_enu[1], g.end_enu[1])), g) for g in measured.segments.for_row(i) if g.gap)
        assert len(gaps) == len(truth.gaps), (i, gaps)
        for ((lo, hi), g), (a, b) in zip(gaps, truth.gaps, strict=True):
            assert lo == pytest.approx(a - TRUTH.length_m / 2, abs=0.15)
            assert hi == pytest.approx(b - TRUTH.length_m / 2, abs=0.15)
            assert g.lwa_m2pha() == 0.0 and g.trv_m3pha() == 0.0 and g.cover < 0.1


def test_segments_tile_each_row(measured: DsmCanopy) -> None:
    for i in range(len(TRUTH.rows)):
        segs = measured.segments.for_row(i)
        assert segs[0].s0_m == 0.0
        assert all(a.s1_m == b.s0_m for a, b in zip(segs[:-1], segs[1:], strict=True))


def test_round_trip_and_summary(measured: DsmCanopy) -> None:
    s = measured.segments
    again = CanopySegments.from_dict(s.to_dict())
    assert again == s
    summ = s.summary()
    assert summ["gaps"] == sum(len(r.gaps) for r in TRUTH.rows)
    assert summ["gap_length_m"] == pytest.approx(sum(b - a for r in TRUTH.rows for a, b in r.gaps), abs=0.6)
    assert "LWA" in s.summary_line()


def test_hedge_segments_uniform() -> None:
    rows = [[(0.0, 0.0), (0.0, 10.0)], [(2.5, 0.0), (2.5, 10.0)]]
    segs = hedge_segments(rows, [Hedge(0, 0.5, 1.7, 0.5, 4.0), Hedge(1, 0.5, 0.5, 0.0, 0.0)], 2.5, 2.0)
    r0, r1 = segs.for_row(0), segs.for_row(1)
    assert len(r0) == 5 and all(g.lwa_m2pha() == pytest.approx(9600.0) for g in r0)
    assert all(g.gap for g in r1)
    assert sum(g.volume_m3 for g in r0) == pytest.approx(1.2 * 0.5 * 10.0)


def test_sample_dsm_rows_measured() -> None:
    """The bundled sample: 16 potato rows ~0.9 m apart, ridges ~0.2-0.4 m high, no long gaps along the plots."""
    sample = Path(__file__).resolve().parents[2] / "worlds" / "sample" / "fieldimager_potato_plots_dsm_3cm_utm16n.tif"
    c = measure_dsm_canopy(sample)
    s = c.segments.summary()
    assert s["rows"] == 16
    assert 0.15 < s["wall_height_m"] < 0.45 and 0.3 < s["width_m"] < 0.7
