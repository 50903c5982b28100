"""PyBullet adapter: one ``BulletClient(p.DIRECT)`` per run, terrain, vehicle, fixed step.

Terrain (world ENU, m):

* ``flat``: a static plane at ``flat_z``;
* ``heightmap``: ``GEOM_HEIGHTFIELD`` from the world's height grid (refused above 2^21 samples,
  where PyBullet breaks silently; the AABB is checked after loading, docs/terrain.md §4);
* ``tiles``: one static body per OBJ/STL tile with ``GEOM_FORCE_CONCAVE_TRIMESH`` and mass 0.

Terrain bodies are created with ``useMaximalCoordinates=True`` (plain static collision objects):
as fixed-base multibodies every tile costs time on every step even when nothing touches it
(measured: 27 tiles of the sample world doubled the bare step time).

Contact parameters (chosen so that a vehicle rests without jitter and a 2 m drop does not
tunnel, tests/sim/test_contact.py): restitution 0, lateral friction 1, rolling/spinning
friction 0.001, PyBullet's default ERP/contact solver with 50 iterations, linear/angular
damping 0 (PyBullet's defaults of 0.04 would add fake drag), and a swept-sphere CCD radius on
the vehicle base so fast impacts on thin triangle meshes cannot pass through.
"""

from __future__ import annotations

import atexit
import logging
import math
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from vinecli.constants import STANDARD_GRAVITY
from vinecli.errors import RuntimeFailure, TerrainError
from vinecli.frames import QuatXYZW, Vec3, quat_rotate
from vinecli.world.model import TerrainInfo

__all__ = ["HEIGHTFIELD_MAX_SAMPLES", "Engine", "SettleResult", "rest_pose"]

log = logging.getLogger(__name__)

#: PyBullet's heightfield silently breaks above this many samples (docs/terrain.md §4)
HEIGHTFIELD_MAX_SAMPLES = 2**21


@dataclass(frozen=True)
class SettleResult:
    """Rest pose reached by :meth:`Engine.settle_vehicle`: CoM (m ENU), attitude (FLU -> ENU),
    simulated settling time (s) and whether the vehicle came to rest within the time limit."""

    pos: Vec3
    quat: QuatXYZW
    time_s: float
    settled: bool


class Engine:
    """A PyBullet DIRECT client stepping at a fixed rate with gravity along -z (ENU)."""

    def __init__(self, *, rate_hz: float = 250.0, gravity: float = STANDARD_GRAVITY, solver_iterations: int = 50) -> None:
        from vinecli.world.quiet import c_output_silenced

        with c_output_silenced():  # pybullet printf()s its build time and argv[0]
            import pybullet as p
            from pybullet_utils.bullet_client import BulletClient

            self.client = BulletClient(connection_mode=p.DIRECT)
        self.p = p
        self.dt = 1.0 / rate_hz
        self.gravity = gravity
        c = self.client
        c.setGravity(0.0, 0.0, -gravity)
        c.setPhysicsEngineParameter(
            fixedTimeStep=self.dt,
            numSubSteps=0,
            numSolverIterations=solver_iterations,
            deterministicOverlappingPairs=1,
        )
        self.terrain_bodies: list[int] = []
        self.vehicle: int = -1
        self.n_links = 0
        # bound methods: avoid attribute look-ups in the loop
        self.step = c.stepSimulation
        self._closed = False

    # ------------------------------------------------------------------ terrain
    def load_terrain(self, terrain: TerrainInfo) -> list[int]:
        """Create the static terrain bodies; returns their ids."""
        if terrain.kind == "flat":
            bodies = [self._plane(terrain.flat_z)]
        elif terrain.kind == "heightmap":
            bodies = [self._heightfield(terrain)]
        elif terrain.kind == "tiles":
            bodies = [self._mesh_tile(f, terrain.offset) for f in terrain.files if f.suffix.lower() in (".obj", ".stl")]
            if not bodies:
                raise TerrainError("tiles terrain has no OBJ/STL files")
        else:
            raise TerrainError(f"unknown terrain kind {terrain.kind!r}")
        for b in bodies:
            self.client.changeDynamics(b, -1, lateralFriction=1.0, restitution=0.0, rollingFriction=0.001,
                                       spinningFriction=0.001)
        self.terrain_bodies = bodies
        return bodies

    def _plane(self, z: float) -> int:
        c, p = self.client, self.p
        shape = c.createCollisionShape(p.GEOM_PLANE, planeNormal=[0, 0, 1])
        return c.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape, basePosition=[0.0, 0.0, z],
                                 useMaximalCoordinates=True)

    def _heightfield(self, terrain: TerrainInfo) -> int:
        c, p = self.client, self.p
        g = terrain.grid
        if g is None:
            raise TerrainError("heightmap terrain without a height grid")
        n = g.nx * g.ny
        if n > HEIGHTFIELD_MAX_SAMPLES:
            raise TerrainError(
                f"heightfield of {g.nx}×{g.ny} = {n} samples exceeds PyBullet's limit of 2^21 "
                "(it fails silently above it); use a smaller heightmap or mesh tiles"
            )
        zmin, zmax = g.z_range
        # PyBullet: data[i + j * rows] with i along x (rows = nx), j along y; the shape is centred
        # on its bounding box, i.e. at the middle of the height range.
        data = g.z.ravel().tolist()
        shape = c.createCollisionShape(
            p.GEOM_HEIGHTFIELD,
            meshScale=[g.dx, g.dy, 1.0],
            heightfieldData=data,
            numHeightfieldRows=g.nx,
            numHeightfieldColumns=g.ny,
        )
        xmin, ymin, xmax, ymax = g.bounds
        centre = [(xmin + xmax) / 2.0, (ymin + ymax) / 2.0, (zmin + zmax) / 2.0]
        body = c.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape, basePosition=centre,
                                 useMaximalCoordinates=True)
        lo, hi = c.getAABB(body)
        tol = 0.1 + 2 * max(g.dx, g.dy)
        if (abs(lo[0] - xmin) > tol or abs(hi[0] - xmax) > tol or abs(lo[1] - ymin) > tol or abs(hi[1] - ymax) > tol
                or lo[2] > zmin + tol or hi[2] < zmax - tol):
            raise TerrainError(
                f"PyBullet heightfield has a wrong bounding box {lo}..{hi} for bounds {g.bounds}, z {zmin}..{zmax}"
            )
        return body

    def _mesh_tile(self, path: Path, offset: Vec3 = (0.0, 0.0, 0.0)) -> int:
        c, p = self.client, self.p
        shape = c.createCollisionShape(p.GEOM_MESH, fileName=str(path), flags=p.GEOM_FORCE_CONCAVE_TRIMESH,
                                       meshScale=[1.0, 1.0, 1.0])
        if shape < 0:
            raise TerrainError("PyBullet could not load the mesh tile", path=path)
        return c.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape, basePosition=list(offset),
                                 useMaximalCoordinates=True)

    # ------------------------------------------------------------------ vehicle
    def load_vehicle(self, urdf: Path, pos: Vec3, quat: QuatXYZW, *, ccd_radius: float = 0.02) -> int:
        """Load the vehicle URDF at ``pos`` (CoM, m ENU) with attitude ``quat`` (FLU -> ENU)."""
        c, p = self.client, self.p
        try:
            body = c.loadURDF(str(urdf), basePosition=list(pos), baseOrientation=list(quat),
                              flags=p.URDF_USE_INERTIA_FROM_FILE)
        except p.error as exc:
            raise RuntimeFailure(f"PyBullet could not load the vehicle URDF: {exc}") from None
        self.vehicle = body
        self.n_links = c.getNumJoints(body)
        for link in range(-1, self.n_links):
            c.changeDynamics(body, link, linearDamping=0.0, angularDamping=0.0, lateralFriction=1.0,
                             restitution=0.0, rollingFriction=0.001, spinningFriction=0.001)
        c.changeDynamics(body, -1, ccdSweptSphereRadius=ccd_radius)
        return body

    def remove_vehicle(self) -> None:
        """Remove the vehicle body (the terrain stays loaded for the next run)."""
        if self.vehicle >= 0:
            self.client.removeBody(self.vehicle)
            self.vehicle = -1
            self.n_links = 0

    def reset_vehicle(self, pos: Vec3, quat: QuatXYZW, vel: Vec3, omega_world: Vec3) -> None:
        """Teleport the vehicle (m ENU, FLU -> ENU) and set its velocities (m/s, rad/s world)."""
        c = self.client
        c.resetBasePositionAndOrientation(self.vehicle, list(pos), list(quat))
        c.resetBaseVelocity(self.vehicle, list(vel), list(omega_world))

    def settle_vehicle(self, *, liquid_kg: float = 0.0, mount_flu: Vec3 = (0.0, 0.0, 0.0), max_s: float = 3.0,
                       v_tol: float = 1e-3, w_tol: float = 1e-2, hold_s: float = 0.1) -> SettleResult:
        """Let the (motors-off) vehicle come to rest on the terrain before the run's clock starts.

        Steps the world with gravity and the liquid weight ``liquid_kg · g`` (down, at the tank mount
        ``mount_flu``, m body FLU) until |v| < ``v_tol`` m/s and |ω| < ``w_tol`` rad/s for ``hold_s``
        (or ``max_s`` simulated seconds), then zeroes the velocities. A vehicle placed on a slope or
        a ridge tilts or slides here, not after t = 0 (no spurious contact events in the run).
        """
        c, p, b = self.client, self.p, self.vehicle
        wz = -liquid_kg * self.gravity
        hold = max(1, int(round(hold_s / self.dt)))
        calm = 0
        k = 0
        n_max = max(1, int(round(max_s / self.dt)))
        settled = False
        while k < n_max:
            if wz != 0.0:
                pos, q = c.getBasePositionAndOrientation(b)
                r = quat_rotate(q, mount_flu)
                c.applyExternalForce(b, -1, (0.0, 0.0, wz), (pos[0] + r[0], pos[1] + r[1], pos[2] + r[2]),
                                     p.WORLD_FRAME)
            c.stepSimulation()
            k += 1
            v, w = c.getBaseVelocity(b)
            if math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2) < v_tol and math.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2) < w_tol:
                calm += 1
                if calm >= hold:
                    settled = True
                    break
            else:
                calm = 0
        pos, q = c.getBasePositionAndOrientation(b)
        c.resetBaseVelocity(b, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
        if not settled:
            log.warning("vehicle still moving after %.1f s of settling at the spawn", k * self.dt)
        return SettleResult(tuple(pos), tuple(q), k * self.dt, settled)  # type: ignore[arg-type]

    def in_contact(self) -> bool:
        """True if the vehicle touches any terrain body."""
        return bool(self.client.getContactPoints(bodyA=self.vehicle))

    def footprint_height(self, x: float, y: float, half_x: float, half_y: float, yaw: float, n: int = 7) -> float | None:
        """Highest terrain point (m) under a rectangle centred at (x, y) with yaw (rad), from n×n rays."""
        c, s = math.cos(yaw), math.sin(yaw)
        starts, ends = [], []
        for i in range(n):
            u = -half_x + 2.0 * half_x * i / (n - 1)
            for j in range(n):
                v = -half_y + 2.0 * half_y * j / (n - 1)
                px, py = x + c * u - s * v, y + s * u + c * v
                starts.append([px, py, 1e4])
                ends.append([px, py, -1e4])
        hits = [h[3][2] for h in self.client.rayTestBatch(starts, ends) if h[0] >= 0 and h[0] != self.vehicle]
        return max(hits) if hits else None

    def ray_height(self, x: float, y: float, z_top: float = 1e4, z_bottom: float = -1e4) -> float | None:
        """Terrain height (m) straight below (x, y) from a ray cast, None if it misses."""
        hit = self.client.rayTest([x, y, z_top], [x, y, z_bottom])[0]
        if hit[0] < 0:
            return None
        return float(hit[3][2])

    def close(self) -> None:
        """Disconnect the client (idempotent)."""
        if not self._closed:
            self._closed = True
            try:
                self.client.disconnect()
            except Exception:  # noqa: BLE001 - already gone
                log.debug("PyBullet client already disconnected")

    def __enter__(self) -> Engine:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _TerrainEngines(threading.local):
    """At most one kept engine per thread (Dask may run cases in threads), for the terrain it was last
    asked for (see :func:`terrain_engine`)."""

    def __init__(self) -> None:
        self.enabled = False
        self.key: tuple[object, ...] | None = None
        self.engine: Engine | None = None

    def drop(self) -> None:
        if self.engine is not None:
            self.engine.close()
        self.key, self.engine = None, None


_KEPT = _TerrainEngines()
_DROP_AT_EXIT = False  # _KEPT.drop registered with atexit (the main thread's kept engine)


def reuse_terrain_engines(enabled: bool = True) -> None:
    """Keep the engine of the last terrain in this thread across runs (batch workers: a case on the same
    world skips connecting PyBullet and loading its tiles). Runs stay bit-identical to fresh engines: the
    engine is created with ``deterministicOverlappingPairs`` and only the vehicle body is removed between
    runs (checked against fresh engines in tests/world/test_engine_reuse.py)."""
    global _DROP_AT_EXIT
    _KEPT.enabled = enabled
    if not enabled:
        _KEPT.drop()
    elif not _DROP_AT_EXIT:  # disconnect before the interpreter tears pybullet down (a noisy __del__ otherwise)
        _DROP_AT_EXIT = True
        atexit.register(_KEPT.drop)


def _terrain_key(terrain: TerrainInfo, rate_hz: float, gravity: float) -> tuple[object, ...]:
    """What makes a loaded terrain the same one: its kind, files (with size and mtime), offset, flat height,
    the grid's geometry, the step rate and gravity."""
    files = tuple((str(f), f.stat().st_size, f.stat().st_mtime_ns) for f in terrain.files if f.exists())
    g = terrain.grid
    grid = None if g is None else (g.x0, g.y0, g.dx, g.dy, g.z.shape, float(g.z.sum()))
    return (terrain.kind, files, tuple(terrain.offset), terrain.flat_z, grid, rate_hz, gravity)


@contextmanager
def terrain_engine(terrain: TerrainInfo, *, rate_hz: float, gravity: float) -> Iterator[Engine]:
    """An engine with ``terrain`` loaded, for one run. Closed afterwards, unless
    :func:`reuse_terrain_engines` is on: then the same engine serves the next run on the same terrain
    (its vehicle removed after each run); a run that fails drops it."""
    if not _KEPT.enabled:
        with Engine(rate_hz=rate_hz, gravity=gravity) as engine:
            engine.load_terrain(terrain)
            yield engine
        return
    key = _terrain_key(terrain, rate_hz, gravity)
    if _KEPT.key != key or _KEPT.engine is None:
        _KEPT.drop()
        engine = Engine(rate_hz=rate_hz, gravity=gravity)
        try:
            engine.load_terrain(terrain)
        except BaseException:
            engine.close()
            raise
        _KEPT.key, _KEPT.engine = key, engine
    engine = _KEPT.engine
    try:
        yield engine
    except BaseException:
        _KEPT.drop()
        raise
    engine.remove_vehicle()


# parameters: keyword-only options, each with its default (the vehicle's box, gear, liquid and the engine's rate and gravity); a caller names the ones it sets
def rest_pose(terrain: TerrainInfo, urdf: Path, *, x: float, y: float, yaw: float, z_guess: float,
              collision_box_m: Vec3, landing_gear_height_m: float, liquid_kg: float = 0.0,
              mount_flu: Vec3 = (0.0, 0.0, 0.0), rate_hz: float = 250.0, gravity: float = STANDARD_GRAVITY) -> SettleResult:
    """Where a vehicle placed at (x, y, yaw) on ``terrain`` comes to rest (as the runner settles it).

    Skids on the highest ray hit under the collision box (``z_guess`` CoM z if the rays miss), then
    :meth:`Engine.settle_vehicle` with the liquid weight at the mount. Used by ``world build`` to
    report the rest attitude at the spawn.
    """
    from vinecli.frames import quat_from_euler

    with Engine(rate_hz=rate_hz, gravity=gravity) as eng:
        eng.load_terrain(terrain)
        quat = quat_from_euler(0.0, 0.0, yaw)
        ground = eng.footprint_height(x, y, collision_box_m[0] / 2.0, collision_box_m[1] / 2.0, yaw)
        pos = (x, y, ground + landing_gear_height_m if ground is not None else z_guess)
        eng.load_vehicle(urdf, pos, quat)
        eng.reset_vehicle(pos, quat, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        return eng.settle_vehicle(liquid_kg=liquid_kg, mount_flu=mount_flu)
