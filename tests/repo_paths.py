"""Repository paths and the optional ../shared data folder, importable from any test module
(``from repo_paths import REPO, shared_files``; a module named ``conftest`` is ambiguous when
several test folders have one)."""

from __future__ import annotations

import os
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TEST_DATA = REPO / "tests" / "data"
SHARED_DATA = Path(os.environ.get("VINECLI_SHARED_DATA", REPO.parent / "shared" / "data"))


def shared_files(sub: str, pattern: str) -> list[Path]:
    """Files of ../shared/data/<sub> matching pattern, or [] when ../shared is absent (fresh clone)."""
    d = SHARED_DATA / sub
    return sorted(d.glob(pattern)) if d.is_dir() else []


VEHICLES = REPO / "vehicles"
