"""Depth camera: PyBullet ``getCameraImage`` (ER_TINY_RENDERER) -> point cloud in the world frame.

Frames: the camera frame is FLU-like (x = optical axis, y left, z up) and mounted on the body
with ``mount.position_m`` and ``mount.rpy_deg`` (roll, pitch, yaw about the body axes; the
default pitch 60° looks forward and down). A pixel's depth buffer value d ∈ [0, 1] is
linearised to the distance along the optical axis ``z = f n / (f - (f - n) d)``, back-projected
with the vertical field of view, and carried through the chain
``p_world = p_body + R_body (r_mount + R_mount p_cam)`` (all rotations via :mod:`vinecli.frames`).
Pixels at the far plane (no hit) are dropped. The vehicle's own body would fill the image
(TinyRenderer draws collision shapes and ignores transparency), so during a capture it is
moved 10 km below the world and put back at exactly the same pose (velocities untouched).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vinecli.frames import QuatXYZW, Vec3, quat_from_euler, quat_mul, quat_to_matrix
from vinecli.specs.vehicle import DepthCameraSpec

__all__ = ["DepthCamera"]


class DepthCamera:
    """A depth camera rendering through a PyBullet client; :meth:`capture` returns (N, 3) world points."""

    def __init__(self, client: Any, spec: DepthCameraSpec, *, rng: np.random.Generator | None = None,
                 hide_body: int | None = None) -> None:
        import pybullet as p

        self.client = client
        self.spec = spec
        self.hide_body = hide_body
        self.renderer = p.ER_TINY_RENDERER
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.w, self.h = int(spec.width_px), int(spec.height_px)
        self.aspect = self.w / self.h
        self.near, self.far = float(spec.near_m), float(spec.far_m)
        self.proj = client.computeProjectionMatrixFOV(spec.fov_deg, self.aspect, self.near, self.far)
        r, pch, y = (math.radians(a) for a in spec.mount.rpy_deg)
        self.q_mount: QuatXYZW = quat_from_euler(r, pch, y)
        self.r_mount: Vec3 = tuple(float(c) for c in spec.mount.position_m)  # type: ignore[assignment]
        tv = math.tan(math.radians(spec.fov_deg) / 2.0)
        th = tv * self.aspect
        u = (2.0 * (np.arange(self.w) + 0.5) / self.w - 1.0) * th  # right positive
        # TinyRenderer samples image row i at (i + 1)/h from the top (measured: a camera pitched 60°
        # over a plane gives |z| < 1e-4 m with this, 0.07 m with pixel centres)
        v = (1.0 - 2.0 * (np.arange(self.h) + 1.0) / self.h) * tv  # up positive
        self._uu, self._vv = np.meshgrid(u, v)  # (h, w)

    def pose(self, pos: Vec3, quat: QuatXYZW) -> tuple[Vec3, QuatXYZW]:
        """Camera position (m ENU) and attitude (camera -> ENU) for a body pose."""
        R = quat_to_matrix(quat)
        rx, ry, rz = self.r_mount
        cam = (
            pos[0] + R[0][0] * rx + R[0][1] * ry + R[0][2] * rz,
            pos[1] + R[1][0] * rx + R[1][1] * ry + R[1][2] * rz,
            pos[2] + R[2][0] * rx + R[2][1] * ry + R[2][2] * rz,
        )
        return cam, quat_mul(quat, self.q_mount)

    def capture(self, pos: Vec3, quat: QuatXYZW) -> np.ndarray:
        """Render at the body pose (m ENU, FLU -> ENU) and return hit points (N, 3) float32, world ENU."""
        cam, qc = self.pose(pos, quat)
        Rc = np.array(quat_to_matrix(qc))
        fwd, up = Rc[:, 0], Rc[:, 2]
        target = (cam[0] + fwd[0], cam[1] + fwd[1], cam[2] + fwd[2])
        view = self.client.computeViewMatrix(cam, target, up.tolist())
        c = self.client
        if self.hide_body is not None:
            vel, omega = c.getBaseVelocity(self.hide_body)
            c.resetBasePositionAndOrientation(self.hide_body, [pos[0], pos[1], pos[2] - 1e4], list(quat))
        try:
            _w, _h, _rgb, depth, _seg = c.getCameraImage(self.w, self.h, view, self.proj, renderer=self.renderer,
                                                         flags=0)
        finally:
            if self.hide_body is not None:
                c.resetBasePositionAndOrientation(self.hide_body, list(pos), list(quat))
                c.resetBaseVelocity(self.hide_body, vel, omega)
        d = np.reshape(np.asarray(depth, dtype=np.float64), (self.h, self.w))
        hit = d < 1.0 - 1e-7
        zc = self.far * self.near / (self.far - (self.far - self.near) * d[hit])
        if self.spec.depth_noise_m > 0:
            zc = zc + self.rng.normal(0.0, self.spec.depth_noise_m, zc.shape)
        # camera frame: x forward (depth), y left (= -right), z up
        pc = np.column_stack([zc, -self._uu[hit] * zc, self._vv[hit] * zc])
        pts = pc @ Rc.T + np.asarray(cam)
        return pts.astype(np.float32)
