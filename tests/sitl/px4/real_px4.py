"""Real PX4 SITL for tests: the ``../shared/px4/*.tar.gz`` build extracted once per session.

``px4_bin`` (session): ``PX4_SITL_BIN`` if set, else the newest tarball in ``../shared/px4/``
(``VINECLI_SHARED_PX4`` overrides the folder) extracted into a session temp dir; the test is
skipped, with the reason, only when neither exists (a fresh clone without ``../shared``).
``real_px4`` (per test): a factory of :class:`Px4SitlAutopilot` objects that each start their own
PX4 process on a free instance number with a fresh working directory under ``tmp_path``
(``px4-N/px4.log`` stays there for debugging); every one is closed (PX4 stopped) at teardown.
"""

from __future__ import annotations

import os
import tarfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.repo_paths import REPO
from vinecli.sitl.px4.backend import Px4SitlAutopilot

SHARED_PX4 = Path(os.environ.get("VINECLI_SHARED_PX4", REPO.parent / "shared" / "px4"))


def px4_tarballs() -> list[Path]:
    """PX4 SITL tarballs in ../shared/px4 ([] when the folder is absent)."""
    return sorted(SHARED_PX4.glob("*.tar.gz")) if SHARED_PX4.is_dir() else []


def extract_px4(tarball: Path, dest: Path) -> Path:
    """Extract a PX4 SITL tarball into ``dest``; the path of its ``bin/px4``."""
    with tarfile.open(tarball) as tf:
        tf.extractall(dest, filter="data")
    found = sorted(dest.glob("*/bin/px4")) + sorted(dest.glob("bin/px4"))
    if not found:
        raise FileNotFoundError(f"{tarball}: no bin/px4 inside")
    return found[0]


@pytest.fixture(scope="session")
def px4_bin(tmp_path_factory: pytest.TempPathFactory) -> Path:
    env = os.environ.get("PX4_SITL_BIN")
    if env:
        return Path(env)
    tars = px4_tarballs()
    if not tars:
        pytest.skip(f"no PX4 SITL tarball in {SHARED_PX4} (../shared is absent; CI has it)")
    return extract_px4(tars[-1], tmp_path_factory.mktemp("px4-sitl"))


@pytest.fixture
def real_px4(px4_bin: Path, tmp_path: Path) -> Iterator[Callable[..., Px4SitlAutopilot]]:
    made: list[Px4SitlAutopilot] = []

    def make(**opts: Any) -> Px4SitlAutopilot:
        opts.setdefault("px4_workdir", str(tmp_path / f"px4-{len(made)}"))
        ap = Px4SitlAutopilot(px4_bin=str(px4_bin), **opts)
        made.append(ap)
        return ap

    yield make
    for ap in made:
        ap.close()
