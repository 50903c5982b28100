"""What the MAVLink tests share: free loopback ports and a flat world at :data:`ORIGIN` made without
``world build`` (the built-in autopilot's endpoint, the fake and the real PX4 peers fly over it)."""

from __future__ import annotations

import socket
from pathlib import Path

from vinecli.geo import GeoOrigin
from vinecli.vehicle import load_vehicle
from vinecli.vehicle.urdf import write_urdf
from vinecli.world import TerrainInfo, World, rest_position

ORIGIN = GeoOrigin(46.0705, 11.1204, 210.0)  # Trentino vineyard latitude/longitude, m AMSL


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    """A port that is free on 127.0.0.1 for ``kind`` (TCP or UDP) right now."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def flat_world(tmp: Path, vehicle: str = "x500-sprayer", rows: list[list[tuple[float, float]]] | None = None) -> World:
    """A flat built world at :data:`ORIGIN` (terrain z = 0) without going through `world build`."""
    veh = load_vehicle(vehicle)
    terrain = TerrainInfo(kind="flat", bounds=(-60.0, -60.0, 60.0, 60.0), z_range=(0.0, 0.0), flat_z=0.0)
    urdf = write_urdf(veh, tmp / f"{veh.name}.urdf")
    return World(name="flat-px4", dir=tmp, origin=ORIGIN, terrain=terrain, vehicle=veh, urdf=urdf,
                 spawn_enu=rest_position(terrain, veh, 0.0, 0.0), vine_rows_enu=rows or [])
