"""Real ArduCopter SITL for tests: ``../shared/ardupilot``'s tarball, extracted once into a cache dir.

``ardupilot_bin`` (session): ``ARDUPILOT_SITL_BIN`` if set, else the newest tarball in
``../shared/ardupilot/`` (``VINECLI_SHARED_ARDUPILOT`` overrides the folder), extracted once into
``$XDG_CACHE_HOME/vinecli/sitl/<tarball name>/`` (``~/.cache`` by default; an extraction is renamed into
place whole, so a killed test run leaves no half tree), reused by later sessions. The tests skip, with
the reason, only when neither exists (a fresh clone without ``../shared``).
"""

from __future__ import annotations

import os
import shutil
import tarfile
import tempfile
from pathlib import Path

import pytest

from tests.repo_paths import REPO

SHARED_ARDUPILOT = Path(os.environ.get("VINECLI_SHARED_ARDUPILOT", REPO.parent / "shared" / "ardupilot"))


def sitl_cache() -> Path:
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "vinecli" / "sitl"


def cached_extract(tarball: Path, binary_glob: str) -> Path:
    """``tarball`` extracted under :func:`sitl_cache` (once); the path of the file matching ``binary_glob``."""
    dest = sitl_cache() / tarball.name.removesuffix(".tar.gz")
    if not dest.is_dir():
        dest.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=".extract-", dir=dest.parent))
        with tarfile.open(tarball) as tf:
            tf.extractall(tmp, filter="data")
        try:
            tmp.rename(dest)
        except OSError:  # another session extracted it first
            shutil.rmtree(tmp, ignore_errors=True)
    found = sorted(dest.glob(binary_glob))
    if not found:
        raise FileNotFoundError(f"{tarball}: no {binary_glob} inside")
    return found[0]


@pytest.fixture(scope="session")
def ardupilot_bin() -> Path:
    env = os.environ.get("ARDUPILOT_SITL_BIN")
    if env:
        return Path(env)
    tars = sorted(SHARED_ARDUPILOT.glob("*.tar.gz")) if SHARED_ARDUPILOT.is_dir() else []
    if not tars:
        pytest.skip(f"no ArduCopter SITL tarball in {SHARED_ARDUPILOT} (../shared is absent; CI has it)")
    return cached_extract(tars[-1], "*/bin/arducopter")
