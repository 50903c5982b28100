"""Fixtures for the simulation tests: a loaded flat world (the built worlds are in tests/conftest.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest


@pytest.fixture()
def flat_world(flat_world_dir: Path) -> Any:
    from vinecli.world import load_world

    return load_world(flat_world_dir)
