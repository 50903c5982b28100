"""The canopy-band mask of the deposition metrics (missions/deposition_metrics.near_polylines): the same cells as the
distance to every row segment over the whole grid, on random rows (straight, bent, crossing, outside the grid)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vinecli.geometry import point_polyline_distance
from vinecli.missions.deposition_metrics import near_polylines

_XC = np.arange(-10.0, 10.0, 0.1) + 0.05
_YC = np.arange(-15.0, 15.0, 0.1) + 0.05
_GX, _GY = np.meshgrid(_XC, _YC)

_point = st.tuples(st.floats(-14.0, 14.0), st.floats(-20.0, 20.0))


@settings(max_examples=40, deadline=None)
@given(lines=st.lists(st.lists(_point, min_size=2, max_size=4), min_size=1, max_size=6),
       reach=st.floats(0.05, 1.5))
def test_the_band_mask_is_the_cells_within_reach_of_any_row(lines: list, reach: float) -> None:
    expected = point_polyline_distance(_GX, _GY, lines) <= reach
    assert np.array_equal(near_polylines(_XC, _YC, lines, reach), expected)
