"""Canopy segmentation of the bundled sample DSM (target: under 2 s) against a baseline in the same run: the
row detection alone on the same DSM (what ``plan rows`` and ``world build`` already do). Interleaved, median of
``--repeats``; prints seconds and the ratio.

    .venv/bin/python benchmarks/canopy_segments.py --repeats 5
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from vinecli.rows.dsm_canopy import measure_dsm_canopy
from vinecli.rows.source import detect_rows_in_dsm

SAMPLE = Path(__file__).resolve().parents[1] / "worlds" / "sample" / "fieldimager_potato_plots_dsm_3cm_utm16n.tif"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    measure_dsm_canopy(SAMPLE)  # warm imports and caches
    base, seg = [], []
    for _ in range(args.repeats):
        t = time.perf_counter()
        detect_rows_in_dsm(SAMPLE)
        base.append(time.perf_counter() - t)
        t = time.perf_counter()
        c = measure_dsm_canopy(SAMPLE)
        seg.append(time.perf_counter() - t)
    b, s = statistics.median(base), statistics.median(seg)
    print(f"sample DSM: {c.segments.summary_line()}")
    print(f"row detection (baseline) {b:.3f} s; detection + canopy segmentation {s:.3f} s "
          f"(segmentation alone {s - b:.3f} s); ratio {s / b:.2f}; target < 2 s: {'met' if s < 2.0 else 'MISSED'}")


if __name__ == "__main__":
    main()
