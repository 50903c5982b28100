"""Worlds: ``worlds/*.yaml`` specs (:mod:`~vinecli.world.spec`), ``world build`` (:mod:`~vinecli.world.build`:
world.json, URDF, SDF, terrain, canopy), ``load_world`` (:mod:`~vinecli.world.model`) and the PyBullet engine a run
steps (:mod:`~vinecli.world.engine`).

May import every floor below it (terrain, rows, GIS files, the autopilot's preflight for the spawn); never the
simulator or anything above it."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from vinecli.world.model import TerrainInfo, World, load_world, rest_position

if TYPE_CHECKING:
    from vinecli.world.build import build_world

__all__ = ["TerrainInfo", "World", "build_world", "load_world", "rest_position"]


def __getattr__(name: str) -> Any:
    if name == "build_world":
        from vinecli.world.build import build_world

        return build_world
    raise AttributeError(name)
