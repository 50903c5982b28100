"""Row detection on real drone surveys against row lines digitised by hand (tests/data/rows_truth_*, see
tests/data/README.md for how): exact row count, median / 95th-percentile centre-line distance to the truth."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pyproj import Transformer
from repo_paths import REPO, TEST_DATA
from shapely.geometry import LineString

from vinecli.rows.source import RowFrame, detect_rows_in_dsm

#: survey DSM, hand-digitised truth, (row count, median m, 95th percentile m) the README's accuracy table claims
SURVEYS = {
    "fieldimager-potato-dsm1": (REPO / "worlds" / "sample" / "fieldimager_potato_plots_dsm_3cm_utm16n.tif",
                                TEST_DATA / "rows_truth_fieldimager_dsm1.geojson", (16, 0.05, 0.15)),
    "fieldimager-potato-bare-dsm0": (TEST_DATA / "fieldimager_potato_bare_dsm0_3cm_utm16n.tif",
                                     TEST_DATA / "rows_truth_fieldimager_dsm0.geojson", (16, 0.05, 0.15)),
    "bisonfly-wheat-plots-dap49": (TEST_DATA / "bisonfly_wheat_plots_dsm_11cm_dap49.tif",
                                   TEST_DATA / "rows_truth_bisonfly_dap49.json", (22, 0.05, 0.15)),
    "bisonfly-wheat-plots-dap52": (TEST_DATA / "bisonfly_wheat_plots_dsm_11cm_dap52.tif",
                                   TEST_DATA / "rows_truth_bisonfly_dap52.json", (22, 0.05, 0.15)),
}


def truth_rows(path: Path, frame: RowFrame) -> list[LineString]:
    """The hand-digitised rows in the detector's local metres: a ``.geojson`` holds RFC 7946 WGS84 lon/lat, a
    ``.json`` the DSM's own CRS coordinates (``rows``: one list of (x, y) per row)."""
    doc = json.loads(path.read_text())
    if path.suffix == ".geojson":
        to_crs = Transformer.from_crs("EPSG:4326", frame.crs, always_xy=True)
        lines = [[to_crs.transform(*p) for p in f["geometry"]["coordinates"]] for f in doc["features"]]
    else:
        lines = doc["rows"]
    return [LineString(frame.from_crs([(float(x), float(y)) for x, y in line])) for line in lines]


def centre_line_distances(det: list[LineString], truth: list[LineString]) -> np.ndarray:
    """Distances (m) from points every 5 cm along each truth row's nearest detected row to that truth row,
    where they project inside the digitised stretch."""
    out = []
    for t in truth:
        mid = t.interpolate(0.5, normalized=True)
        d = det[int(np.argmin([x.distance(mid) for x in det]))]
        for s in np.arange(0.0, d.length, 0.05):
            p = d.interpolate(s)
            if 0.0 < t.project(p) < t.length:
                out.append(t.distance(p))
    return np.asarray(out)


@pytest.mark.parametrize("name", list(SURVEYS))
def test_detected_rows_match_the_hand_digitised_rows(name: str) -> None:
    dsm, truth_path, (count, median_m, p95_m) = SURVEYS[name]
    r = detect_rows_in_dsm(dsm)
    truth = truth_rows(Path(truth_path), r.frame)
    assert len(truth) == count and len(r.detection.rows) == count
    d = centre_line_distances([LineString(x) for x in r.detection.rows], truth)
    assert d.size > 1000
    assert float(np.median(d)) <= median_m and float(np.percentile(d, 95)) <= p95_m
