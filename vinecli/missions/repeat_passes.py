"""How many times each piece of a row was sprayed over, for a spray phase that repeats its passes until the tank is
empty (``until: empty``): its dose is judged per pass (docs/deposition.md), the rate on a piece against the asked
rate times the passes that sprayed it. World ENU m.

A pass over a row is a run of the nozzle path's emission points (:attr:`~vinecli.spray.deposition.Parcels.path_xy`,
in time order, only while spraying) within ``half_width_m`` of the row, without a jump of more than ``JUMP_M``
between neighbours (the sections closed in a turn) or a reversal along the row (a turn back onto it); it counts on
every ``segment_m`` piece between its first and last point along the row.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vinecli.geometry import Polyline, distance_along, polyline_length

__all__ = ["JUMP_M", "passes_per_piece"]

#: a gap between consecutive emission points longer than this ends a pass (sections closed), m
JUMP_M = 1.0


def passes_per_piece(path_xy: np.ndarray, rows: Sequence[Polyline], half_width_m: float, segment_m: float
                     ) -> list[np.ndarray]:
    """Per row: the number of passes (int array) over each ``segment_m`` piece of it (module docstring)."""
    path = np.asarray(path_xy, dtype=np.float64).reshape(-1, 2)
    out = []
    for line in rows:
        length = polyline_length(line)
        n = max(1, int(np.ceil(length / segment_m - 1e-9)))
        count = np.zeros(n, dtype=np.int64)
        if path.shape[0] and len(line) >= 2:
            d, s = distance_along(path[:, 0], path[:, 1], line)
            inside = d <= half_width_m
            ds = np.diff(s)
            step = np.hypot(*np.diff(path, axis=0).T) if path.shape[0] > 1 else np.zeros(0)
            way = np.sign(ds)
            turned = np.concatenate([[False], (way[1:] * way[:-1]) < 0]) if ds.size else ds.astype(bool)
            joined = inside[:-1] & inside[1:] & (step <= JUMP_M) & ~turned  # sample i and i + 1: one pass
            start = np.flatnonzero(inside & ~np.concatenate([[False], joined]))
            for a in start:
                b = a
                while b < joined.size and joined[b]:
                    b += 1
                lo, hi = float(np.min(s[a:b + 1])), float(np.max(s[a:b + 1]))
                i0 = int(np.clip(np.floor(max(lo, 0.0) / segment_m), 0, n - 1))
                i1 = int(np.clip(np.ceil(min(hi, length) / segment_m) - 1, 0, n - 1))
                if hi > 0.0 and lo < length and i1 >= i0:
                    count[i0:i1 + 1] += 1
        out.append(count)
    return out
