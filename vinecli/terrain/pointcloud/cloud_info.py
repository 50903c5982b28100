"""One-screen facts about a point cloud, for ``vinecli terrain info CLOUD``.

:func:`cloud_info` returns a JSON-able dict; the CLI renders it. Nothing is written.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.errors import TerrainError
from vinecli.terrain.pointcloud import prep
from vinecli.terrain.pointcloud.readers import read_cloud
from vinecli.terrain.pointcloud.units import cloud_units, crs_summary, to_metres

log = logging.getLogger(__name__)

#: LAS classification names (ASPRS LAS 1.4 R15, table 17) for the histogram.
LAS_CLASS_NAMES = {
    0: "never classified", 1: "unclassified", 2: "ground", 3: "low vegetation", 4: "medium vegetation",
    5: "high vegetation", 6: "building", 7: "low point (noise)", 8: "reserved/model key", 9: "water",
    10: "rail", 11: "road surface", 12: "reserved/overlap", 13: "wire guard", 14: "wire conductor",
    15: "transmission tower", 16: "wire connector", 17: "bridge deck", 18: "high noise",
}


def cloud_info(path: str | Path) -> dict[str, Any]:
    """Facts about a point cloud and what ``terrain reconstruct`` would do with it by default.

    Keys: path, kind ("pointcloud"), format, header, points, nonfinite_points,
    duplicate_points, crs (name/epsg/is_compound or None), units, bounds (file units) and bounds_m
    (both [minx, miny, minz, maxx, maxy, maxz]),
    extent_m, z_range_m, classes ({code: {"name", "count"}} after dropping NaN and
    duplicates, or None), density_per_m2 (points
    per m² over the x-y bounding box), spacing_m (mean/median nearest-neighbour, metres),
    reconstruct (default voxel, points after voxel, d, radii), notes (list of hints).
    Raises TerrainError/InputError naming the file for unreadable or degenerate clouds.
    """
    path = Path(path)
    raw = read_cloud(path)
    xyz = raw.xyz
    finite = prep.finite_mask(xyz)
    n_in = len(xyz)
    n_nan = int(n_in - finite.sum())
    if n_nan == n_in:
        raise TerrainError(f"all {n_in} points have NaN/inf coordinates", path=path)
    xyz_f = xyz[finite]
    uniq = prep.unique_mask(xyz_f)
    n_dup = int(len(xyz_f) - uniq.sum())
    xyz_u = xyz_f[uniq]
    units = cloud_units(raw)
    xyz_m, crs_m = to_metres(xyz_u, raw.crs, units)
    lo, hi = xyz_m.min(axis=0), xyz_m.max(axis=0)
    extent = hi - lo
    area = float(extent[0] * extent[1])
    local = xyz_m - np.round(xyz_m.mean(axis=0))
    mean_nn, median_nn = prep.nn_spacing(local) if len(local) >= 2 else (math.nan, math.nan)

    classes = None
    if raw.classification is not None:
        codes, counts = np.unique(raw.classification[finite][uniq], return_counts=True)
        classes = {int(c): {"name": LAS_CLASS_NAMES.get(int(c), "user defined"), "count": int(k)}
                   for c, k in zip(codes, counts, strict=True)}

    plan: dict[str, Any] = {"method": "bpa (ball pivoting), or --method delaunay25d"}
    notes: list[str] = []
    if len(xyz_u) >= 3 and median_nn > 0:
        voxel = prep.default_voxel(median_nn)
        after = prep.voxel_count(local, voxel)
        d_est = mean_nn * math.sqrt(max(len(xyz_u), 1) / max(after, 1))
        plan.update(voxel_m=round(voxel, 4), points_after_voxel=after, d_estimate_m=round(d_est, 4),
                    radii_estimate_m=[round(f * d_est, 4) for f in (2, 4, 8)])
        if after > 1_000_000:
            notes.append(f"{after:,} points after the default voxel: ball pivoting is slow above 1M points; "
                         "use --max-points or a larger --voxel")
    else:
        notes.append("fewer than 3 distinct points or all coincident: reconstruct will refuse this cloud")
    if n_nan:
        notes.append(f"{n_nan} points with NaN/inf coordinates will be dropped")
    if n_dup:
        notes.append(f"{n_dup} exact duplicate points will be removed")
    if raw.crs is None:
        notes.append("no CRS: coordinates taken as metres; outputs carry no CRS")
    if units.xy_to_m != 1.0 or units.z_to_m != 1.0:
        notes.append(f"units: x/y in {units.xy_unit}, z in {units.z_unit} ({units.z_source}) -> converted to metres")
    if units.geographic:
        notes.append(f"geographic CRS: reprojected to {crs_m.name if crs_m is not None else 'UTM'}")
    if classes and 2 in classes and len(classes) > 1:
        notes.append(f"{len(classes)} classes: for bare terrain use --classes 2 "
                     f"({classes[2]['count']:,} ground points); vegetation splits a BPA mesh into many pieces")
    if max(abs(float(v)) for v in (*lo, *hi)) > 1e5:
        notes.append("large coordinates: reconstruct subtracts the mean (offset recorded in stats.json)")

    return {
        "path": str(path),
        "kind": "pointcloud",
        "format": raw.format,
        "header": raw.header,
        "points": n_in,
        "nonfinite_points": n_nan,
        "duplicate_points": n_dup,
        "crs": crs_summary(raw.crs, wkt=False),
        "metric_crs": None if crs_m is None else crs_m.name,
        "units": units.to_dict(),
        "bounds": [round(float(v), 3) for v in (*xyz_f.min(axis=0), *xyz_f.max(axis=0))],
        "bounds_m": [round(float(v), 3) for v in (*lo, *hi)],
        "extent_m": [round(float(v), 3) for v in extent],
        "z_range_m": [round(float(lo[2]), 3), round(float(hi[2]), 3)],
        "classes": classes,
        "density_per_m2": round(len(xyz_u) / area, 4) if area > 0 else None,
        "spacing_m": {"mean_nn": round(mean_nn, 4), "median_nn": round(median_nn, 4)},
        "reconstruct": plan,
        "notes": notes,
    }
