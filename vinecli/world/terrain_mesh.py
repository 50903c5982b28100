"""Mesh tiles read as PyBullet's own loaders read them, merged into as few collision meshes as PyBullet takes.

A tiles world's terrain goes into PyBullet as ONE static concave mesh (or as few as its size limits allow)
instead of one body per tile: a static body costs every step whether or not anything touches it (its
bounding box is updated and paired in the broadphase), and the vehicle on a tile border meets one mesh, not
two. The triangles are the tiles' own, vertex for vertex: :func:`read_mesh` parses an OBJ written as the
terrain conversion writes it (``v x y z`` / ``f a b c`` lines, ``#`` comments) or a binary STL and rounds
the coordinates to float32, as PyBullet's OBJ and STL loaders store them; any other file (normals, texture
coordinates, polygons, ASCII STL...) returns None and is loaded by PyBullet from the file. The ray heights
and contacts of the merged mesh are those of the tiles, bit for bit (tests/world/test_terrain_mesh.py).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["MAX_INDICES", "MAX_VERTICES", "Mesh", "fits", "merge_meshes", "read_mesh"]

#: most vertices and triangle indices PyBullet's createCollisionShape takes for one mesh (measured on 3.2.7:
#: 131,073 vertices or 524,289 indices fail)
MAX_VERTICES = 131_072
MAX_INDICES = 524_286  # a multiple of 3 below 524,288

_STL_TRIANGLE = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])


@dataclass(frozen=True)
class Mesh:
    """Triangles: ``vertices`` (n, 3) float64 holding float32 values (m, the mesh's frame), ``faces`` (m, 3)
    int64 indices into them."""

    vertices: np.ndarray
    faces: np.ndarray


def _obj(data: bytes) -> Mesh | None:
    lines = [line for line in data.split(b"\n") if line.strip() and not line.startswith(b"#")]
    nv = sum(1 for line in lines if line.startswith(b"v "))
    if nv == 0 or not all(line.startswith(b"v ") for line in lines[:nv]):
        return None
    if not all(line.startswith(b"f ") for line in lines[nv:]):  # (a "1/2/3" index stops the parse below)
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy warns (and stops) at a token that is not a number
        try:
            values = np.fromstring(b" ".join(lines).translate(None, b"vf\r"), sep=" ")
        except (DeprecationWarning, ValueError):
            return None
    if values.size != 3 * len(lines):
        return None
    faces_f = values[3 * nv :].reshape(-1, 3)
    faces = faces_f.astype(np.int64)
    if (faces != faces_f).any() or faces.min(initial=1) < 1 or faces.max(initial=1) > nv:
        return None
    return Mesh(values[: 3 * nv].reshape(-1, 3).astype(np.float32).astype(np.float64), faces - 1)


def _stl(data: bytes) -> Mesh | None:
    if len(data) < 84:
        return None
    n = int(np.frombuffer(data, "<u4", 1, 80)[0])
    if len(data) != 84 + 50 * n or n == 0:
        return None  # ASCII STL
    tris = np.frombuffer(data, _STL_TRIANGLE, n, 84)
    return Mesh(tris["v"].reshape(-1, 3).astype(np.float64), np.arange(3 * n, dtype=np.int64).reshape(-1, 3))


def read_mesh(path: Path) -> Mesh | None:
    """The triangles of an OBJ or binary STL mesh file as PyBullet reads them (module doc), or None when the
    file is not one this reader takes (PyBullet then reads it)."""
    suffix = path.suffix.lower()
    if suffix not in (".obj", ".stl"):
        return None
    data = path.read_bytes()
    return _obj(data) if suffix == ".obj" else _stl(data)


def merge_meshes(meshes: Iterable[Mesh], *, max_vertices: int = MAX_VERTICES,
                 max_indices: int = MAX_INDICES) -> Iterator[Mesh]:
    """The meshes in order, concatenated into as few meshes as PyBullet takes (``max_vertices``, ``max_indices``
    each; a mesh larger than that on its own is yielded alone: callers check :func:`fits`)."""
    vs: list[np.ndarray] = []
    fs: list[np.ndarray] = []
    nv = nf = 0
    for m in meshes:
        if vs and (nv + len(m.vertices) > max_vertices or 3 * (nf + len(m.faces)) > max_indices):
            yield Mesh(np.concatenate(vs), np.concatenate(fs))
            vs, fs, nv, nf = [], [], 0, 0
        vs.append(m.vertices)
        fs.append(m.faces + nv)
        nv += len(m.vertices)
        nf += len(m.faces)
    if vs:
        yield Mesh(np.concatenate(vs), np.concatenate(fs))


def fits(mesh: Mesh) -> bool:
    """True when PyBullet takes ``mesh`` as one collision shape."""
    return len(mesh.vertices) <= MAX_VERTICES and 3 * len(mesh.faces) <= MAX_INDICES
