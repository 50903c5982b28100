"""Fixtures the safety tests share."""

from __future__ import annotations

from pathlib import Path

import pytest
from attack_kit import ROWS_WORLD, cli


@pytest.fixture(scope="module")
def rows_world(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A flat world with two rows, built once (the tests copy it before aiming outputs into it)."""
    d = tmp_path_factory.mktemp("rw")
    (d / "w.yaml").write_text(ROWS_WORLD)
    r = cli("world", "build", d / "w.yaml", "--out", d / "world")
    assert r.exit_code == 0, r.output
    return d / "world"
