"""Fixtures for the simulation tests: built worlds (flat, synthetic bumpy DSM as tiles and heightmap)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest


@pytest.fixture()
def flat_world(flat_world_dir: Path) -> Any:
    from vinecli.world import load_world

    return load_world(flat_world_dir)
