"""Depth camera: point cloud in the world frame through world <- body <- camera."""

from __future__ import annotations

import math

import numpy as np
import pytest
from sim_helpers import OpenLoop, mission

from vinecli.frames import quat_from_euler
from vinecli.sim.camera import DepthCamera
from vinecli.sim.runner import run_simulation
from vinecli.specs.vehicle import DepthCameraSpec
from vinecli.world.engine import Engine
from vinecli.world.model import TerrainInfo


def test_camera_straight_down_over_flat_ground(flat_world):
    h, cam_dz = 6.0, -0.2
    spec = DepthCameraSpec(enabled=True, width_px=80, height_px=60, fov_deg=60.0,
                           mount={"position_m": (0.1, 0.0, cam_dz), "rpy_deg": (0.0, 90.0, 0.0)})
    with Engine() as e:
        e.load_terrain(TerrainInfo("flat"))
        body = e.load_vehicle(flat_world.urdf, (2.0, 3.0, h), (0.0, 0.0, 0.0, 1.0))
        for yaw in (0.0, math.radians(30.0)):
            cam = DepthCamera(e.client, spec, hide_body=body)
            q = quat_from_euler(0.0, 0.0, yaw)
            e.reset_vehicle((2.0, 3.0, h), q, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
            pts = cam.capture((2.0, 3.0, h), q)
            assert pts.shape == (80 * 60, 3)
            assert np.abs(pts[:, 2]).max() < 1e-3
            # footprint: vertical FOV along the body x axis, horizontal FOV along body y
            cx, cy = 2.0 + 0.1 * math.cos(yaw), 3.0 + 0.1 * math.sin(yaw)
            rel = pts[:, :2] - (cx, cy)
            along = rel @ (math.cos(yaw), math.sin(yaw))
            across = rel @ (-math.sin(yaw), math.cos(yaw))
            dist = h - abs(cam_dz)
            half_v = dist * math.tan(math.radians(30.0))
            half_h = half_v * 80 / 60
            assert np.abs(along).max() == pytest.approx(half_v, rel=0.05)
            assert np.abs(across).max() == pytest.approx(half_h, rel=0.05)
            pix = 2 * half_v / 60  # one pixel on the ground
            assert abs(along.mean()) < pix and abs(across.mean()) < pix
        # the body was put back with its pose
        assert e.client.getBasePositionAndOrientation(body)[0] == pytest.approx((2.0, 3.0, h))


def test_camera_forward_sees_a_wall_at_its_distance(flat_world):
    spec = DepthCameraSpec(enabled=True, width_px=64, height_px=48, fov_deg=50.0, far_m=40.0,
                           mount={"position_m": (0.0, 0.0, 0.0), "rpy_deg": (0.0, 0.0, 0.0)})
    with Engine() as e:
        e.load_terrain(TerrainInfo("flat"))
        c = e.client
        wall = c.createCollisionShape(c.GEOM_BOX, halfExtents=[20.0, 0.5, 20.0])
        c.createMultiBody(0.0, wall, basePosition=[0.0, 10.5, 0.0])  # face at y = 10 (north)
        cam = DepthCamera(c, spec)
        pts = cam.capture((0.0, 0.0, 3.0), quat_from_euler(0.0, 0.0, math.pi / 2))  # facing north
        on_wall = pts[pts[:, 2] > 0.05]
        assert len(on_wall) > 100
        assert np.allclose(on_wall[:, 1], 10.0, atol=0.02)


def test_camera_in_the_loop(flat_world):
    v = flat_world.vehicle
    cam = v.sensors.depth_camera.model_copy(update={"enabled": True, "rate_hz": 5.0})
    v2 = v.model_copy(update={"sensors": v.sensors.model_copy(update={"depth_camera": cam})})
    w = v.hover_speed(v.dry_mass() + 1.0)
    phase = {"type": "open_loop", "duration_s": 1.0, "rotor_speeds_rad_s": w,
             "initial_state": {"position_enu": [0.0, 0.0, 4.0]}}
    r = run_simulation(flat_world, mission([phase], max_duration_s=1.0), OpenLoop(lambda o: [w] * 4), seed=1,
                       vehicle=v2)
    assert [t for t, _ in r.point_clouds] == pytest.approx([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
    for _t, pts in r.point_clouds:
        assert len(pts) > 0 and np.abs(pts[:, 2]).max() < 0.01
    # hovering: identical motion with and without the camera (capturing does not disturb the body)
    r0 = run_simulation(flat_world, mission([phase], max_duration_s=1.0), OpenLoop(lambda o: [w] * 4), seed=1)
    assert np.allclose(r.timeseries["pos_enu_z_m"], r0.timeseries["pos_enu_z_m"], atol=1e-9)
