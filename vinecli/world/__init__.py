"""Worlds: ``worlds/*.yaml`` specs, ``world build`` (world.json, URDF, SDF, terrain) and ``load_world``."""

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
