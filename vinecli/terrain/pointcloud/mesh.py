"""Point cloud -> triangle mesh: voxel resampling, normals, ball pivoting, hole filling, 2.5-D Delaunay.

Coordinates are local metres (the cloud minus its offset, see :mod:`vinecli.terrain.pointcloud`);
x east, y north, z up. Meshes are ``(V, F)`` pairs: V (n, 3) float64, F (m, 3) int64.
Measured defaults are in docs/terrain.md §2: radii [2d, 4d, 8d] from the mean
nearest-neighbour spacing d, normals oriented +z, then ``fill_holes``.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vinecli.terrain.pointcloud.o3d import o3d

log = logging.getLogger(__name__)

#: Ball-pivoting radii as multiples of the mean nearest-neighbour spacing d (docs/terrain.md §2).
RADII_FACTORS = (2.0, 4.0, 8.0)


def voxel_resample(points: np.ndarray, voxel: float) -> np.ndarray:
    """Open3D voxel-grid downsample: one point (the mean) per occupied voxel of edge ``voxel`` (m)."""
    pcd = o3d().geometry.PointCloud(o3d().utility.Vector3dVector(np.ascontiguousarray(points, dtype=np.float64)))
    return np.asarray(pcd.voxel_down_sample(float(voxel)).points, dtype=np.float64)


def estimate_normals(points: np.ndarray, spacing: float, *, max_nn: int = 30) -> np.ndarray:
    """Unit normals from local PCA (radius 4 d, at most ``max_nn`` neighbours), oriented towards +z."""
    lib = o3d()
    pcd = lib.geometry.PointCloud(lib.utility.Vector3dVector(points))
    pcd.estimate_normals(lib.geometry.KDTreeSearchParamHybrid(radius=4.0 * spacing, max_nn=max_nn))
    pcd.orient_normals_to_align_with_direction(np.array([0.0, 0.0, 1.0]))
    return np.asarray(pcd.normals, dtype=np.float64)


def ball_pivot(points: np.ndarray, normals: np.ndarray, radii: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """Open3D ball pivoting; returns (V, F) with V = the input points (unused ones stay unreferenced)."""
    lib = o3d()
    pcd = lib.geometry.PointCloud(lib.utility.Vector3dVector(points))
    pcd.normals = lib.utility.Vector3dVector(normals)
    mesh = lib.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(
        pcd, lib.utility.DoubleVector([float(r) for r in radii]))
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.triangles, dtype=np.int64).reshape(-1, 3)


def delaunay25d(points: np.ndarray, *, max_edge: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """2.5-D Delaunay triangulation on (x, y), triangles counter-clockwise seen from above (+z normals).

    With ``max_edge`` (m), triangles on the outer boundary whose boundary edge is longer than
    ``max_edge`` in plan view are peeled away repeatedly (long slivers along a concave hull);
    only boundary triangles are removed, so no interior hole is created.
    """
    from scipy.spatial import Delaunay

    tri = Delaunay(points[:, :2])
    faces = tri.simplices.astype(np.int64)
    xy = points[:, :2]
    a, b, c = xy[faces[:, 0]], xy[faces[:, 1]], xy[faces[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    cw = cross < 0
    if max_edge is not None and max_edge > 0:
        alive = _peel_long_hull_edges(xy, faces, tri.neighbors.astype(np.int64), float(max_edge))
        faces, cw = faces[alive], cw[alive]
    faces[cw] = faces[cw][:, [0, 2, 1]]
    return points, faces


def _peel_long_hull_edges(xy: np.ndarray, faces: np.ndarray, neighbors: np.ndarray, max_edge: float) -> np.ndarray:
    """Alive mask after repeatedly removing boundary triangles whose boundary edge is > max_edge."""
    # Edge k of a scipy simplex is opposite vertex k; its neighbour across it is neighbors[:, k].
    edge_len = np.empty(faces.shape, dtype=np.float64)
    for k in range(3):
        p = xy[faces[:, (k + 1) % 3]]
        q = xy[faces[:, (k + 2) % 3]]
        edge_len[:, k] = np.hypot(*(p - q).T)
    long_edge = edge_len > max_edge
    alive = np.ones(len(faces), dtype=bool)
    while True:
        across_dead = np.where(neighbors >= 0, ~alive[np.maximum(neighbors, 0)], True)
        remove = alive & np.any(across_dead & long_edge, axis=1)
        if not remove.any():
            return alive
        alive &= ~remove


# --------------------------------------------------------------------------- mesh topology


@dataclass
class _Topology:
    edges: np.ndarray  # (E, 2) unique undirected edges, sorted vertex ids
    counts: np.ndarray  # (E,) triangles per edge
    vertex_component: np.ndarray  # (n,) component label of each vertex (via triangle edges)
    boundary: np.ndarray  # (B, 2) boundary edges (used by one triangle)
    boundary_label: np.ndarray  # (n,) loop label of each vertex, -1 if not on the boundary
    outer_loops: set[int]  # loop labels that are the outer boundary of their component


def _topology(vertices: np.ndarray, faces: np.ndarray) -> _Topology:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(vertices)
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e.sort(axis=1)
    key = e[:, 0] * np.int64(n + 1) + e[:, 1]
    _, first, counts = np.unique(key, return_index=True, return_counts=True)
    edges = e[first]
    ones = np.ones(len(edges), dtype=np.int8)
    graph = coo_matrix((ones, (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, comp = connected_components(graph, directed=False)
    boundary = edges[counts == 1]
    label = np.full(n, -1, dtype=np.int64)
    outer: set[int] = set()
    if len(boundary):
        bgraph = coo_matrix((np.ones(len(boundary), dtype=np.int8), (boundary[:, 0], boundary[:, 1])), shape=(n, n))
        _, blab = connected_components(bgraph, directed=False)
        on_b = np.zeros(n, dtype=bool)
        on_b[boundary.ravel()] = True
        label[on_b] = blab[on_b]
        loop_of_edge = blab[boundary[:, 0]]
        length = np.linalg.norm(vertices[boundary[:, 0]] - vertices[boundary[:, 1]], axis=1)
        loops, inv = np.unique(loop_of_edge, return_inverse=True)
        perimeter = np.bincount(inv, weights=length)
        loop_comp = comp[boundary[np.unique(inv, return_index=True)[1], 0]]
        # The longest loop of each component is its outer boundary; the others are holes.
        order = np.lexsort((-perimeter, loop_comp))
        first_of_comp = np.ones(len(order), dtype=bool)
        first_of_comp[1:] = loop_comp[order][1:] != loop_comp[order][:-1]
        outer = {int(x) for x in loops[order][first_of_comp]}
    return _Topology(edges, counts, comp, boundary, label, outer)


def mesh_stats(vertices: np.ndarray, faces: np.ndarray) -> dict[str, Any]:
    """Topology and size of a triangle mesh.

    ``boundary_loops``: connected chains of boundary edges (edges of one triangle);
    ``holes``: boundary loops other than the outer boundary (longest loop) of each component;
    ``components``: connected pieces (triangles linked through shared vertices);
    ``non_manifold_edges``: edges shared by more than two triangles; ``area_m2``: total area;
    ``unused_points``: vertices no triangle references; ``downward_triangles``: normals with z < 0.
    """
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    n = len(vertices)
    if len(faces) == 0:
        return {"vertices": n, "triangles": 0, "boundary_loops": 0, "holes": 0, "components": 0,
                "non_manifold_edges": 0, "boundary_edges": 0, "area_m2": 0.0, "unused_points": n,
                "downward_triangles": 0}
    topo = _topology(vertices, faces)
    used = np.zeros(n, dtype=bool)
    used[faces.ravel()] = True
    components = len(np.unique(topo.vertex_component[used]))
    loops = np.unique(topo.boundary_label[topo.boundary_label >= 0])
    cross = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    return {
        "vertices": n,
        "triangles": int(len(faces)),
        "boundary_loops": int(len(loops)),
        "holes": int(len(loops) - len(topo.outer_loops)),
        "components": int(components),
        "non_manifold_edges": int(np.count_nonzero(topo.counts > 2)),
        "boundary_edges": int(len(topo.boundary)),
        "area_m2": float(0.5 * np.linalg.norm(cross, axis=1).sum()),
        "unused_points": int(n - np.count_nonzero(used)),
        "downward_triangles": int(np.count_nonzero(cross[:, 2] < 0)),
    }


def fill_holes(vertices: np.ndarray, faces: np.ndarray, *, hole_size: float = 1e6) -> tuple[np.ndarray, int]:
    """Fill holes with Open3D's ``t.geometry.TriangleMesh.fill_holes`` (VTK); return (faces, patches kept).

    VTK also caps outer boundaries (it would lay a second sheet over the whole terrain and
    close every small fragment) and may orient a patch against its surroundings. So: patches
    on the outer boundary loop of a component are dropped, and each kept patch is flipped
    when its edges along the loop run the same way as the mesh's (inconsistent orientation).
    ``hole_size`` is VTK's limit on the radius of a hole's bounding sphere (m).
    """
    if len(faces) == 0:
        return faces, 0
    lib = o3d()
    topo = _topology(vertices, faces)
    holes = set(np.unique(topo.boundary_label[topo.boundary_label >= 0]).tolist()) - topo.outer_loops
    if not holes:
        return faces, 0
    mesh = lib.t.geometry.TriangleMesh(lib.core.Tensor(np.ascontiguousarray(vertices, dtype=np.float64)),
                                       lib.core.Tensor(np.ascontiguousarray(faces, dtype=np.int32)))
    filled = mesh.fill_holes(hole_size=float(hole_size))
    v2 = filled.vertex.positions.numpy()
    f2 = filled.triangle.indices.numpy().astype(np.int64)
    if len(v2) != len(vertices) or not np.array_equal(f2[: len(faces)], faces):
        log.warning("fill_holes changed existing vertices or triangles; keeping the unfilled mesh")
        return faces, 0
    new = f2[len(faces):]
    if len(new) == 0:
        return faces, 0
    loop = topo.boundary_label[new[:, 0]]
    keep = np.isin(loop, np.fromiter(holes, dtype=np.int64)) & np.all(topo.boundary_label[new] == loop[:, None], axis=1)
    new, loop = new[keep], loop[keep]
    if len(new) == 0:
        return faces, 0
    # Orientation: an original directed edge (a, b) must appear as (b, a) in a consistent patch.
    n = np.int64(len(vertices) + 1)
    orig_directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    orig_keys = np.unique(orig_directed[:, 0] * n + orig_directed[:, 1])
    d = np.concatenate([new[:, [0, 1]], new[:, [1, 2]], new[:, [2, 0]]])
    edge_loop = np.concatenate([loop, loop, loop])
    same = np.isin(d[:, 0] * n + d[:, 1], orig_keys)
    opposite = np.isin(d[:, 1] * n + d[:, 0], orig_keys)
    labels, inv = np.unique(edge_loop, return_inverse=True)
    votes = np.bincount(inv, weights=same.astype(np.float64) - opposite, minlength=len(labels))
    flip_loops = labels[votes > 0]
    flip = np.isin(loop, flip_loops)
    new[flip] = new[flip][:, [0, 2, 1]]
    return np.concatenate([faces, new]), int(len(np.unique(loop)))
