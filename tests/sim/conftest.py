"""Fixtures of the simulation tests: the flat world loaded (the bumpy DSM's worlds are tests/conftest.py's)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest


@pytest.fixture()
def flat_world(flat_world_dir: Path) -> Any:
    from vinecli.world import load_world

    return load_world(flat_world_dir)
