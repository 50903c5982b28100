"""A tiles world goes into PyBullet as one merged concave mesh (vinecli/world/terrain_mesh.py): the ground it
gives must be the tiles' own, against one body per tile loaded by PyBullet from the files (how the terrain went
in before): the same height under every point of a dense grid of rays, and the same rest pose of a vehicle set
down on it. Where more than four triangle contacts compete for a contact manifold's four points,
Bullet keeps the ones it meets in its own order, which the merged mesh's tree changes: there the rest pose
moves by micrometres and turns by hundredths of a degree (measured <= 34 um, 0.06 deg on the bumpy world); at the sample world's spawn, where the golden runs
start, it is bit for bit the same."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from vinecli.world import load_world
from vinecli.world.engine import Engine
from vinecli.world.terrain_mesh import Mesh, merge_meshes, read_mesh


def _tile_bodies(eng: Engine, files: list[Path], offset: Any) -> list[int]:
    """One static body per tile, PyBullet reading each file (the reference)."""
    c, p = eng.client, eng.p
    bodies = []
    for f in files:
        shape = c.createCollisionShape(p.GEOM_MESH, fileName=str(f), flags=p.GEOM_FORCE_CONCAVE_TRIMESH)
        b = c.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape, basePosition=list(offset),
                              useMaximalCoordinates=True)
        c.changeDynamics(b, -1, lateralFriction=1.0, restitution=0.0, rollingFriction=0.001, spinningFriction=0.001)
        bodies.append(b)
    return bodies


def _rays(eng: Engine, bounds: Any, step: float) -> np.ndarray:
    xmin, ymin, xmax, ymax = bounds
    xs, ys = np.arange(xmin + 1e-3, xmax, step), np.arange(ymin + 1e-3, ymax, step)
    pts = [(x, y) for y in ys for x in xs]
    out = []
    for k in range(0, len(pts), 8192):
        chunk = pts[k : k + 8192]
        hits = eng.client.rayTestBatch([[x, y, 100.0] for x, y in chunk], [[x, y, -100.0] for x, y in chunk])
        out += [h[3][2] if h[0] >= 0 else np.nan for h in hits]
    return np.array(out)


def _rest(eng: Engine, world: Any, x: float, y: float) -> tuple[Any, ...]:
    """Where the world's vehicle comes to rest set down at (x, y), and its contacts with the ground."""
    ground = eng.footprint_height(x, y, 0.2, 0.2, 0.0)
    pos = (x, y, ground + world.vehicle.frame.landing_gear_height_m)
    eng.load_vehicle(world.urdf, pos, (0.0, 0.0, 0.0, 1.0))
    rest = eng.settle_vehicle()
    contacts = sorted((cp[5], cp[8]) for cp in eng.client.getContactPoints(bodyA=eng.vehicle))
    eng.remove_vehicle()
    return rest.pos, rest.quat, rest.time_s, contacts


@pytest.mark.parametrize("which", ["bumpy", "sample"])
def test_the_merged_mesh_is_the_tiles_ground(which: str, bumpy_worlds: dict[str, Path], sample_world_dir: Path) -> None:
    world = load_world(bumpy_worlds["tiles"] if which == "bumpy" else sample_world_dir)
    t = world.terrain
    files = [f for f in t.files if f.suffix == ".obj"]
    assert len(files) > 4  # several tiles, and borders between them
    with Engine() as merged, Engine() as tiles:
        assert len(merged.load_terrain(t)) == 1
        _tile_bodies(tiles, files, t.offset)
        step = 0.04 if which == "bumpy" else 0.1  # ~360 k and ~130 k rays
        a, b = _rays(merged, t.bounds, step), _rays(tiles, t.bounds, step)
        assert np.isfinite(a).all() and np.isfinite(b).all()
        # bit for bit but where a ray grazes a triangle's edge: Bullet's ray test takes hits a hair outside a
        # triangle, which the merged mesh's tree may offer in another order (2 of 130,340 rays on the sample, 24 um)
        differ = a != b
        assert differ.mean() < 1e-4 and np.abs(a - b).max() < 1e-4
        spawn = world.spawn_enu[0], world.spawn_enu[1]
        if which == "sample":  # where the golden runs start: bit for bit
            assert _rest(merged, world, *spawn) == _rest(tiles, world, *spawn)
        for x, y in [spawn, (3.0, 3.0), (-3.0, 2.0), (-9.0, -9.0)] if which == "bumpy" else []:
            (pa, qa, _ta, ca), (pb, qb, _tb, cb) = _rest(merged, world, x, y), _rest(tiles, world, x, y)
            assert np.allclose(pa, pb, rtol=0.0, atol=1e-4) and np.allclose(qa, qb, rtol=0.0, atol=2e-3)
            assert len(ca) == len(cb) and np.allclose([c[0] for c in ca], [c[0] for c in cb], rtol=0.0, atol=2e-3)


def test_meshes_merge_within_pybullets_limits_and_keep_their_triangles() -> None:
    tri = Mesh(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), np.array([[0, 1, 2]]))
    merged = list(merge_meshes([tri] * 5, max_vertices=7, max_indices=9))
    assert [len(m.faces) for m in merged] == [2, 2, 1]
    assert merged[0].faces.tolist() == [[0, 1, 2], [3, 4, 5]]
    assert np.array_equal(merged[0].vertices[merged[0].faces[1]], tri.vertices)


def test_only_plain_obj_and_binary_stl_are_read_here(tmp_path: Path) -> None:
    plain = tmp_path / "a.obj"
    plain.write_text("# made by hand\nv 0 0 0.1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    m = read_mesh(plain)
    assert m is not None and m.faces.tolist() == [[0, 1, 2]]
    assert m.vertices[0, 2] == float(np.float32(0.1))  # float32, as PyBullet's loader stores it
    for text in ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",  # normals: PyBullet reads the file
                 "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 4\n",  # a quad
                 "v 0 0 0\nv 1 0 0\nf 1 2 3\n"):  # an index past the vertices
        plain.write_text(text)
        assert read_mesh(plain) is None
    stl = tmp_path / "b.stl"
    tri = np.zeros(1, dtype=[("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    tri["v"] = [[[0, 0, 0.1], [1, 0, 0], [0, 1, 0]]]
    stl.write_bytes(b"\0" * 80 + np.uint32(1).tobytes() + tri.tobytes())
    m = read_mesh(stl)
    assert m is not None and m.faces.tolist() == [[0, 1, 2]] and m.vertices[0, 2] == float(np.float32(0.1))
    stl.write_text("solid x\nendsolid x\n")
    assert read_mesh(stl) is None
