"""``terrain reconstruct``: point cloud (LAS/LAZ/PLY/PCD/XYZ) -> mesh.obj + stats.json (+ optional DSM).

Pipeline (each stage timed into ``stats.json["seconds"]``):

1. read (:mod:`~vinecli.terrain.pointcloud.readers`), drop NaN/inf points, drop exact duplicates,
   filter by classification and bounding box (file CRS units);
2. convert to metres (:mod:`~vinecli.terrain.pointcloud.units`; feet, US feet, degrees);
3. optional DSM GeoTIFF from the filtered cloud (:mod:`~vinecli.terrain.pointcloud.dsm`);
4. centre: subtract the offset (mean, rounded to whole metres) so large UTM coordinates stay
   well conditioned; the mesh is in these local metres (x east, y north, z up);
5. voxel-grid resampling (default voxel: twice the median NN spacing), spacing d measured;
6. ``bpa``: normals oriented +z, ball pivoting with radii [2d, 4d, 8d], hole filling;
   ``delaunay25d``: 2.5-D Delaunay on (x, y), hole-free;
7. topology statistics before/after filling, OBJ and JSON written atomically.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from contextlib import AbstractContextManager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from vinecli.errors import InputError, TerrainError
from vinecli.outputs import Manifest, atomic_output_dir, check_output_target, timed_stage, write_json
from vinecli.terrain.defaults import RECONSTRUCT_METHOD
from vinecli.terrain.pointcloud import prep
from vinecli.terrain.pointcloud.readers import RawCloud, read_cloud
from vinecli.terrain.pointcloud.units import CloudUnits, cloud_units, crs_summary, to_metres

log = logging.getLogger(__name__)

Method = Literal["bpa", "delaunay25d"]
METHODS: tuple[str, ...] = ("bpa", "delaunay25d")
#: Open3D ball pivoting gets slow above this many points (docs/terrain.md §2, isl-org/Open3D#6272).
BPA_SLOW_POINTS = 1_000_000


@dataclass(frozen=True)
class ReconstructOptions:
    """Options of :func:`reconstruct_cloud` (lengths in metres unless stated).

    ``voxel``: voxel edge; None = default from the measured spacing, 0 = no resampling.
    ``radii``: ball-pivoting radii; None = [2d, 4d, 8d]. ``classes``: keep only these LAS
    classes. ``bbox``: (minx, miny, maxx, maxy) in the file's CRS units. ``dsm_res``: also
    write dsm.tif at this resolution. ``max_points``: enlarge the voxel until at most this many
    points remain. ``max_edge``: delaunay25d only, peel hull triangles with longer plan-view
    boundary edges. ``fill_holes``: bpa only.
    """

    method: Method = RECONSTRUCT_METHOD
    voxel: float | None = None
    radii: tuple[float, ...] | None = None
    classes: tuple[int, ...] | None = None
    bbox: tuple[float, float, float, float] | None = None
    dsm_res: float | None = None
    max_points: int | None = None
    max_edge: float | None = None
    fill_holes: bool = True
    overwrite: bool = False

    def validate(self) -> None:
        """Raise InputError for values no cloud could satisfy."""
        if self.method not in METHODS:
            raise InputError(f"--method must be one of {', '.join(METHODS)}, got {self.method!r}")
        if self.voxel is not None and not (self.voxel >= 0 and np.isfinite(self.voxel)):
            raise InputError(f"--voxel must be >= 0 metres, got {self.voxel}")
        if self.radii is not None and (not self.radii or any(not (r > 0 and np.isfinite(r)) for r in self.radii)):
            raise InputError(f"--radii must be positive metres, got {list(self.radii)}")
        if self.dsm_res is not None and not (self.dsm_res > 0 and np.isfinite(self.dsm_res)):
            raise InputError(f"--dsm must be a positive resolution in metres, got {self.dsm_res}")
        if self.max_points is not None and self.max_points < 3:
            raise InputError(f"--max-points must be at least 3, got {self.max_points}")
        if self.max_edge is not None and not (self.max_edge >= 0):
            raise InputError(f"--max-edge must be >= 0 metres, got {self.max_edge}")
        if self.bbox is not None:
            if len(self.bbox) != 4:
                raise InputError(f"--bbox needs 4 numbers minx,miny,maxx,maxy, got {list(self.bbox)}")
            minx, miny, maxx, maxy = self.bbox
            if not (minx < maxx and miny < maxy):
                raise InputError(f"--bbox must have minx < maxx and miny < maxy, got {list(self.bbox)}")


class _Timer:
    """Seconds per named stage."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    def stage(self, name: str) -> AbstractContextManager[None]:
        """Time a named stage into ``seconds`` (rounded to 0.1 ms)."""
        return timed_stage(self.seconds, name, digits=4)


@dataclass
class CleanCloud:
    """A cloud after NaN/duplicate removal and filters, in metres of ``crs`` (metric CRS or None)."""

    raw: RawCloud
    xyz_m: np.ndarray
    crs: Any
    units: CloudUnits
    counts: dict[str, int]


def load_clean(path: str | Path, *, classes: Sequence[int] | None = None,
               bbox: Sequence[float] | None = None, timer: _Timer | None = None) -> CleanCloud:
    """Read, drop NaN/inf and exact duplicates, filter, convert to metres.

    ``counts``: in, nan_dropped, after_nan, duplicates_removed, after_duplicates,
    class_filtered_out, bbox_filtered_out, after_filters. Raises TerrainError (naming the
    file) when nothing usable is left.
    """
    timer = timer or _Timer()
    path = Path(path)
    with timer.stage("read"):
        raw = read_cloud(path)
    with timer.stage("clean"):
        xyz, cls = raw.xyz, raw.classification
        counts = {"in": len(xyz)}
        ok = prep.finite_mask(xyz)
        counts["nan_dropped"] = int(len(xyz) - ok.sum())
        if not ok.any():
            raise TerrainError(f"all {len(xyz)} points have NaN/inf coordinates", path=path)
        xyz, cls = xyz[ok], None if cls is None else cls[ok]
        counts["after_nan"] = len(xyz)
        keep = prep.unique_mask(xyz)
        counts["duplicates_removed"] = int(len(xyz) - keep.sum())
        xyz, cls = xyz[keep], None if cls is None else cls[keep]
        counts["after_duplicates"] = len(xyz)
    with timer.stage("filter"):
        counts["class_filtered_out"] = 0
        counts["bbox_filtered_out"] = 0
        if classes:
            m = prep.class_mask(cls, classes, path)
            counts["class_filtered_out"] = int(len(xyz) - m.sum())
            xyz, cls = xyz[m], cls[m] if cls is not None else None
        if bbox is not None:
            m = prep.bbox_mask(xyz, bbox, path)
            counts["bbox_filtered_out"] = int(len(xyz) - m.sum())
            xyz, cls = xyz[m], cls[m] if cls is not None else None
        counts["after_filters"] = len(xyz)
        if len(xyz) == 0:
            raise TerrainError("no points left after the --classes/--bbox filters", path=path)
    with timer.stage("units"):
        units = cloud_units(raw)
        xyz_m, crs = to_metres(xyz, raw.crs, units)
    return CleanCloud(raw, xyz_m, crs, units, counts)


def reconstruct_cloud(path: str | Path, out: str | Path, options: ReconstructOptions | None = None) -> dict[str, Any]:
    """Mesh a point cloud into ``out``/mesh.obj + stats.json (+ dsm.tif); return the stats dict.

    The output directory is written atomically with a manifest.json; on any error nothing is
    left in ``out``. Mesh coordinates are local metres = metric-CRS coordinates minus
    ``stats["offset_m"]``.
    """
    options = options or ReconstructOptions()
    options.validate()
    path, out = Path(path), Path(out)
    check_output_target(out, overwrite=options.overwrite, inputs=[path], kind="terrain reconstruct")
    timer = _Timer()
    clean = load_clean(path, classes=options.classes, bbox=options.bbox, timer=timer)
    prep.require_surface(clean.xyz_m, path, what="after cleaning and filtering")

    manifest = Manifest(command="terrain reconstruct", parameters=_jsonable_options(options), inputs=[path])
    with atomic_output_dir(out, manifest, overwrite=options.overwrite) as tmp:
        dsm_info = None
        if options.dsm_res is not None:
            from vinecli.terrain.pointcloud.dsm import write_dsm

            with timer.stage("dsm"):
                dsm_info = write_dsm(tmp / "dsm.tif", clean.xyz_m, float(options.dsm_res), clean.crs)
        result = _mesh(clean, options, timer, path)
        vertices, faces = result.pop("_mesh")
        offset = result["offset_m"]
        with timer.stage("write"):
            _write_obj(tmp / "mesh.obj", vertices, faces, offset, clean.crs)
        stats: dict[str, Any] = {
            "input": str(path),
            "format": clean.raw.format,
            "header": clean.raw.header,
            "crs": crs_summary(clean.crs),
            "source_crs": crs_summary(clean.raw.crs),
            "units": clean.units.to_dict(),
            "frame": "local metres: x east, y north, z up = CRS coordinates (metres) minus offset_m",
            "points": {**clean.counts, "used": result.pop("used")},
            **result,
            "dsm": dsm_info,
            "seconds": timer.seconds,
        }
        stats["seconds"]["total"] = round(sum(v for k, v in timer.seconds.items() if k != "total"), 4)
        write_json(tmp / "stats.json", stats)
        manifest.timings.update(timer.seconds)
        manifest.extra["summary"] = {"method": options.method, "triangles": stats["mesh"]["triangles"],
                                     "holes": stats["mesh"]["holes"], "components": stats["mesh"]["components"]}
    return stats


def _mesh(clean: CleanCloud, options: ReconstructOptions, timer: _Timer, path: Path) -> dict[str, Any]:
    """Centre, resample, mesh and measure; returns stats entries plus ``_mesh`` = (V, F) local metres."""
    from vinecli.terrain.pointcloud import mesh as pm

    with timer.stage("import_open3d"):
        from vinecli.terrain.pointcloud.o3d import o3d

        o3d()
    with timer.stage("centre"):
        offset = np.round(clean.xyz_m.mean(axis=0))
        local = clean.xyz_m - offset
    with timer.stage("spacing_raw"):
        mean_raw, median_raw = prep.nn_spacing(local)
    voxel = options.voxel if options.voxel is not None else prep.default_voxel(median_raw)
    voxel_source = "option" if options.voxel is not None else "2 x median NN spacing"
    enlarged = False
    with timer.stage("voxel"):
        if options.max_points is not None and len(local) > options.max_points:
            base = voxel if voxel > 0 else median_raw
            new_voxel = prep.voxel_for_max_points(local, base, options.max_points)
            enlarged = new_voxel > voxel
            voxel = new_voxel
        points = pm.voxel_resample(local, voxel) if voxel > 0 else local
        if options.max_points is not None and len(points) > options.max_points:
            pick = np.sort(np.random.default_rng(0).choice(len(points), options.max_points, replace=False))
            points = points[pick]
    prep.require_surface(points, path, what="after voxel resampling",
                         plan_view=options.method == "delaunay25d")
    with timer.stage("spacing"):
        d, d_median = prep.nn_spacing(points)
    result: dict[str, Any] = {
        "offset_m": offset.tolist(),
        "used": len(points),
        "spacing_m": {"raw_mean_nn": mean_raw, "raw_median_nn": median_raw, "d": d, "median_nn": d_median},
        "voxel_m": voxel,
        "voxel_source": voxel_source + (" enlarged for --max-points" if enlarged else ""),
        "method": options.method,
    }
    if options.method == "bpa":
        if len(points) > BPA_SLOW_POINTS:
            log.warning("%s: ball pivoting on %d points is slow; consider --max-points or a larger --voxel",
                        path, len(points))
        radii = sorted(options.radii) if options.radii else [f * d for f in pm.RADII_FACTORS]
        with timer.stage("normals"):
            normals = pm.estimate_normals(points, d)
        with timer.stage("bpa"):
            vertices, faces = pm.ball_pivot(points, normals, radii)
        if len(faces) == 0:
            raise TerrainError(f"ball pivoting made no triangles with radii {[round(r, 4) for r in radii]} m "
                               f"(spacing d = {d:.4g} m); try larger --radii or --method delaunay25d", path=path)
        with timer.stage("stats_before_fill"):
            before = pm.mesh_stats(vertices, faces)
        patches = 0
        if options.fill_holes:
            with timer.stage("fill_holes"):
                faces, patches = pm.fill_holes(vertices, faces)
        result["radii_m"] = radii
        result["normals"] = {"method": "PCA radius 4d, max_nn 30", "oriented": "+z"}
    else:
        with timer.stage("delaunay"):
            try:
                vertices, faces = pm.delaunay25d(points, max_edge=options.max_edge)
            except Exception as exc:  # noqa: BLE001 - scipy raises QhullError for degenerate input
                raise TerrainError(f"2.5-D Delaunay failed ({type(exc).__name__}: {exc})", path=path) from exc
        if len(faces) == 0:
            raise TerrainError("2.5-D Delaunay made no triangles (--max-edge too small?)", path=path)
        with timer.stage("stats_before_fill"):
            before = pm.mesh_stats(vertices, faces)
        patches = 0
        result["radii_m"] = None
        result["max_edge_m"] = options.max_edge
    if patches:
        with timer.stage("stats"):
            after = pm.mesh_stats(vertices, faces)
    else:
        after = before
    result["mesh_before_fill"] = before
    result["mesh"] = after
    result["holes_before"] = before["holes"]
    result["holes_after"] = after["holes"]
    result["hole_patches_filled"] = patches
    used = np.unique(faces)
    remap = np.full(len(vertices), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    result["_mesh"] = (vertices[used], remap[faces])
    log.info("%s: %s mesh, %d triangles, holes %d -> %d, %d components", path, options.method,
             after["triangles"], before["holes"], after["holes"], after["components"])
    return result


def _write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray, offset: Sequence[float], crs: Any) -> None:
    """Wavefront OBJ, vertices in local metres (mm precision), 1-based faces, counter-clockwise = +z."""
    with open(path, "w", encoding="ascii", newline="\n") as f:
        f.write("# vinecli terrain reconstruct\n")
        f.write("# local metres: x east, y north, z up = CRS coordinates (metres) minus offset\n")
        f.write(f"# offset_m {offset[0]:.3f} {offset[1]:.3f} {offset[2]:.3f}\n")
        f.write(f"# crs {crs.name if crs is not None else 'none'}\n")
        np.savetxt(f, vertices, fmt="v %.4f %.4f %.4f")
        np.savetxt(f, faces + 1, fmt="f %d %d %d")


def _jsonable_options(options: ReconstructOptions) -> dict[str, Any]:
    d = asdict(options)
    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in d.items()}


def parse_list(text: str | None, option: str, kind: type = float, count: int | None = None) -> tuple[Any, ...] | None:
    """Parse a comma-separated option value (``"2,9"``, ``"0.5,1,2"``); InputError naming the option."""
    if text is None or not str(text).strip():
        return None
    try:
        values = tuple(kind(v) for v in str(text).replace(" ", "").split(",") if v != "")
    except ValueError as exc:
        raise InputError(f"{option} expects comma-separated {kind.__name__} values, got {text!r}") from exc
    if count is not None and len(values) != count:
        raise InputError(f"{option} expects {count} comma-separated values, got {text!r}")
    if not values:
        raise InputError(f"{option} is empty")
    return values
