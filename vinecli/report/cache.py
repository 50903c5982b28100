"""The report's cache of drawn figures and maps, keyed by what they are drawn from, so a second ``vinecli report``
over the same runs draws nothing.

A run's key is a BLAKE2 digest of the content of every file of its run directory, of its world's world.json (the
map's georeference) and terrain grid (the map's hillshade) and of the report's own code (vinecli's version and the source of ``vinecli/report``, its
templates and the map's assets, matplotlib's version): any change to a run or to the drawing code is a new key, so
an entry is never stale. Entries live in ``$VINECLI_CACHE_DIR`` (``off`` disables the cache), else
``$XDG_CACHE_HOME/vinecli/report``, else ``~/.cache/vinecli/report``: one folder per run key, written atomically
(a temporary file, then rename), the least recently used folders removed beyond :data:`MAX_BYTES`. The cache
lives outside the runs: run folders stay exactly as their manifests list them. A cache that cannot be read or
written is no error: the report draws the figures again.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import time
from functools import cache
from pathlib import Path
from typing import Any

__all__ = ["CACHE_ENV", "FigureCache", "cache_root", "code_fingerprint", "run_digest"]

log = logging.getLogger(__name__)
CACHE_ENV = "VINECLI_CACHE_DIR"
MAX_BYTES = 512 * 1024 * 1024
CHUNK = 1 << 20


def cache_root() -> Path | None:
    """Where the cache lives (module docstring); None when ``VINECLI_CACHE_DIR=off``."""
    env = os.environ.get(CACHE_ENV)
    if env is not None:
        return None if env.strip().lower() in ("", "off", "0", "none") else Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "vinecli" / "report"


@cache
def code_fingerprint() -> str:
    """A digest of what draws the figures and maps: vinecli's version, the source of vinecli/report (code,
    templates, map assets) and matplotlib's version."""
    from importlib.metadata import version

    from vinecli import __version__

    h = hashlib.blake2b(digest_size=16)
    h.update(f"{__version__}|{version('matplotlib')}".encode())
    root = Path(__file__).parent
    for p in sorted(root.rglob("*")):
        if p.is_file() and p.suffix in (".py", ".j2", ".js", ".css"):
            h.update(str(p.relative_to(root)).encode())
            h.update(p.read_bytes())
    return h.hexdigest()


def _hash_file(h: Any, p: Path) -> None:
    h.update(f"{p.name}|{p.stat().st_size}|".encode())
    with p.open("rb") as f:
        while chunk := f.read(CHUNK):
            h.update(chunk)


def run_digest(run_dir: Path, world_dir: Path | None) -> str:
    """The cache key of a run: its files, its world's world.json and terrain grid, and :func:`code_fingerprint`."""
    h = hashlib.blake2b(digest_size=20)
    h.update(code_fingerprint().encode())
    for p in sorted(run_dir.iterdir()):
        if p.is_file() and not p.is_symlink():
            _hash_file(h, p)
    for name in ("world.json", "terrain/grid.npz"):  # the georeference; the ground the map's hillshade shows
        if world_dir is not None and (world_dir / name).is_file():
            _hash_file(h, world_dir / name)
    return h.hexdigest()


class FigureCache:
    """Bytes by (run key, item name) under ``root`` (None: a cache that holds nothing)."""

    def __init__(self, root: Path | None) -> None:
        self.root = root
        self.hits = 0
        self.misses = 0

    def _dir(self, key: str) -> Path:
        assert self.root is not None
        return self.root / key[:2] / key

    def get(self, key: str, name: str) -> bytes | None:
        if self.root is None:
            return None
        p = self._dir(key) / name
        try:
            data = p.read_bytes()
            os.utime(p.parent)  # recently used
        except OSError:
            self.misses += 1
            return None
        self.hits += 1
        return data

    def has(self, key: str, name: str) -> bool:
        """Whether the entry is there (without reading it)."""
        return self.root is not None and (self._dir(key) / name).is_file()

    def put(self, key: str, name: str, data: bytes) -> None:
        if self.root is None:
            return
        d = self._dir(key)
        tmp = d / f".{name}.tmp-{os.getpid()}"
        try:
            d.mkdir(parents=True, exist_ok=True)
            tmp.write_bytes(data)
            os.replace(tmp, d / name)
        except OSError as exc:
            log.debug("report cache: cannot write %s: %s", d / name, exc)
            tmp.unlink(missing_ok=True)

    def prune(self, max_bytes: int = MAX_BYTES) -> None:
        """Remove the least recently used run folders until the cache holds at most ``max_bytes``."""
        if self.root is None or not self.root.is_dir():
            return
        try:
            dirs = [(d.stat().st_mtime, d, sum(f.stat().st_size for f in d.iterdir() if f.is_file()))
                    for top in self.root.iterdir() if top.is_dir() for d in top.iterdir() if d.is_dir()]
        except OSError:
            return
        total = sum(s for _, _, s in dirs)
        for _mtime, d, size in sorted(dirs):
            if total <= max_bytes:
                break
            if time.time() - _mtime < 60:  # in use by a report now
                continue
            shutil.rmtree(d, ignore_errors=True)
            total -= size
