"""Synthetic point clouds sampled from an analytic terrain, and writers for every cloud format.

Used by tests/terrain/pointcloud/test_terrain_pointcloud.py, tests/cli/test_cli_terrain_reconstruct.py and
benchmarks/reconstruct.py. The surface is z = f(x, y) in metres around a UTM-sized origin so
the centring path is exercised.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

#: UTM-sized origin (m) added to the synthetic x, y, z.
ORIGIN = (512_000.0, 4_930_000.0, 230.0)


def surface(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Analytic terrain height (m) at local (x, y) (m): rolling hills with a gentle east slope."""
    return 2.0 * np.sin(x / 12.0) + 1.5 * np.cos(y / 9.0) + 0.02 * x


def terrain_cloud(nx: int = 120, ny: int = 100, step: float = 0.5, jitter: float = 0.15, noise: float = 0.0,
                  seed: int = 1) -> np.ndarray:
    """Jittered-grid samples of :func:`surface` over nx*step by ny*step m, shifted by ORIGIN; (N, 3)."""
    rng = np.random.default_rng(seed)
    gx, gy = np.meshgrid(np.arange(nx) * step, np.arange(ny) * step)
    x = gx.ravel() + rng.uniform(-jitter, jitter, gx.size)
    y = gy.ravel() + rng.uniform(-jitter, jitter, gy.size)
    z = surface(x, y) + (rng.normal(0.0, noise, x.size) if noise > 0 else 0.0)
    return np.column_stack((x + ORIGIN[0], y + ORIGIN[1], z + ORIGIN[2]))


def random_terrain_cloud(n: int, size: float, *, noise: float = 0.02, seed: int = 1) -> np.ndarray:
    """``n`` uniformly random samples of :func:`surface` over size x size m (Poisson gaps, like LiDAR), + ORIGIN."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(0.0, size, n), rng.uniform(0.0, size, n)
    z = surface(x, y) + rng.normal(0.0, noise, n)
    return np.column_stack((x + ORIGIN[0], y + ORIGIN[1], z + ORIGIN[2]))


def surface_at(xyz_world: np.ndarray) -> np.ndarray:
    """:func:`surface` evaluated at world coordinates (ORIGIN added), returned in world z (m)."""
    return surface(xyz_world[:, 0] - ORIGIN[0], xyz_world[:, 1] - ORIGIN[1]) + ORIGIN[2]


def write_las(path: Path, xyz: np.ndarray, *, classification: np.ndarray | None = None, crs: Any = None,
              scale: float = 0.001, offsets: tuple[float, float, float] | None = None,
              point_format: int = 3) -> Path:
    """LAS/LAZ (by suffix) with laspy; CRS as GeoTIFF keys (format < 6) or WKT (format >= 6)."""
    import laspy

    header = laspy.LasHeader(point_format=point_format, version="1.2" if point_format < 6 else "1.4")
    header.scales = np.array([scale] * 3)
    if offsets is not None:
        header.offsets = np.asarray(offsets, dtype=np.float64)
    else:
        header.offsets = np.floor(xyz.min(axis=0)) if len(xyz) else np.zeros(3)
    if crs is not None:
        header.add_crs(crs)
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    if classification is not None:
        las.classification = classification.astype(np.uint8)
    las.write(path)
    return path


def write_ply(path: Path, xyz: np.ndarray, *, binary: bool = True, classification: np.ndarray | None = None) -> Path:
    """PLY with double x, y, z (and uchar classification), binary little-endian or ASCII."""
    props = ["property double x", "property double y", "property double z"]
    if classification is not None:
        props.append("property uchar classification")
    fmt = "binary_little_endian" if binary else "ascii"
    header = "\n".join(["ply", f"format {fmt} 1.0", "comment vinecli test", f"element vertex {len(xyz)}", *props,
                        "end_header"]) + "\n"
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        if binary:
            fields = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
            if classification is not None:
                fields.append(("classification", "u1"))
            rec = np.empty(len(xyz), dtype=fields)
            rec["x"], rec["y"], rec["z"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
            if classification is not None:
                rec["classification"] = classification
            f.write(rec.tobytes())
        else:
            for i, p in enumerate(xyz):
                extra = f" {int(classification[i])}" if classification is not None else ""
                f.write((" ".join(repr(float(v)) for v in p) + extra + "\n").encode("ascii"))
    return path


def write_pcd(path: Path, xyz: np.ndarray, *, data: str = "ascii") -> Path:
    """PCD v0.7 with double x, y, z: ``ascii`` or ``binary`` (numpy), ``binary_compressed`` (Open3D, float32)."""
    if data == "binary_compressed":
        import open3d as o3d

        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(xyz))
        o3d.io.write_point_cloud(str(path), pcd, write_ascii=False, compressed=True)
        return path
    header = "\n".join(["# .PCD v0.7", "VERSION 0.7", "FIELDS x y z", "SIZE 8 8 8", "TYPE F F F", "COUNT 1 1 1",
                        f"WIDTH {len(xyz)}", "HEIGHT 1", "VIEWPOINT 0 0 0 1 0 0 0", f"POINTS {len(xyz)}",
                        f"DATA {data}"]) + "\n"
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        if data == "binary":
            f.write(np.ascontiguousarray(xyz, dtype="<f8").tobytes())
        else:
            f.write("".join(" ".join(repr(float(v)) for v in p) + "\n" for p in xyz).encode("ascii"))
    return path


def write_xyz(path: Path, xyz: np.ndarray, *, delimiter: str = " ", header: bool = False) -> Path:
    """Text x y z per line (repr precision), optional ``x,y,z`` header."""
    lines = [delimiter.join(("x", "y", "z"))] if header else []
    lines += [delimiter.join(repr(float(v)) for v in p) for p in xyz]
    path.write_text("\n".join(lines) + "\n", encoding="ascii")
    return path


def read_obj(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(V, F) of an OBJ written by terrain reconstruct (v and f lines; F 0-based)."""
    v, f = [], []
    for line in path.read_text().splitlines():
        if line.startswith("v "):
            v.append([float(t) for t in line.split()[1:4]])
        elif line.startswith("f "):
            f.append([int(t.split("/")[0]) - 1 for t in line.split()[1:4]])
    return np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64)
