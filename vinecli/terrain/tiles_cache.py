"""A cache of mesh-tile conversions (:func:`vinecli.terrain.tiles.convert_to_tiles`), keyed by what they are made
from, so that ``world build`` does not mesh again the tiles ``terrain convert --to tiles`` just made of the same DSM
with the same parameters (``make demo`` does both, seconds of CPU each).

The key is a BLAKE2 digest of the DSM's bytes, the conversion's parameters (error bound, triangle budget, tile
size, mesh format, fill, height unit) and the meshing code (vinecli's version, the source of the terrain modules
that read, fill, mesh and measure, and the versions of the libraries they call): a changed DSM, parameter or
meshing code is a new key, so an entry is never stale. An entry holds a conversion's mesh files and its
tiles.json; a hit copies them byte for byte (tiles.json gets the DSM path of the conversion that asked).

Entries live in ``$VINECLI_TERRAIN_CACHE_DIR`` (``off`` disables the cache), else off when ``VINECLI_CACHE_DIR``
is ``off`` (one switch for vinecli's caches: the test suite's), else ``$XDG_CACHE_HOME/vinecli/terrain``, else
``~/.cache/vinecli/terrain``; one folder per key, written beside and renamed into place (a reader never sees half
an entry). A cache that cannot be read or written is no error: the conversion meshes.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
from functools import cache
from pathlib import Path
from typing import Any

from vinecli.outputs import write_json

__all__ = ["CACHE_ENV", "TilesCache", "tiles_cache_root"]

log = logging.getLogger(__name__)
CACHE_ENV = "VINECLI_TERRAIN_CACHE_DIR"
#: the switch every vinecli cache obeys (vinecli.report.cache)
ALL_CACHES_ENV = "VINECLI_CACHE_DIR"
_OFF = ("", "off", "0", "none")
#: the modules whose code makes the tiles
_CODE = ("tiles.py", "tin.py", "fill.py", "raster.py", "defaults.py")
_LIBRARIES = ("pydelatin", "numpy", "rasterio", "scipy")
CHUNK = 1 << 20


def tiles_cache_root() -> Path | None:
    """Where the cache lives (module docstring); None when it is off."""
    env = os.environ.get(CACHE_ENV)
    if env is not None:
        return None if env.strip().lower() in _OFF else Path(env)
    if os.environ.get(ALL_CACHES_ENV, "x").strip().lower() in _OFF:
        return None
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "vinecli" / "terrain"


@cache
def _code_fingerprint() -> str:
    from importlib.metadata import version

    from vinecli import __version__

    h = hashlib.blake2b(digest_size=16)
    h.update("|".join([__version__, *(version(lib) for lib in _LIBRARIES)]).encode())
    here = Path(__file__).parent
    for name in _CODE:
        h.update(name.encode())
        h.update((here / name).read_bytes())
    return h.hexdigest()


class TilesCache:
    """The cache entry of one conversion: ``key`` under ``root``."""

    def __init__(self, root: Path, key: str) -> None:
        self.root = root
        self.key = key
        self.entry = root / key[:2] / key

    @classmethod
    def for_conversion(cls, dsm: Path, parameters: dict[str, Any]) -> TilesCache | None:
        """The entry of converting ``dsm`` with ``parameters`` (JSON-able); None when the cache is off or the DSM
        cannot be read (the conversion then reports that itself)."""
        root = tiles_cache_root()
        if root is None:
            return None
        h = hashlib.blake2b(digest_size=20)
        h.update(_code_fingerprint().encode())
        h.update(json.dumps(parameters, sort_keys=True).encode())
        try:
            with Path(dsm).open("rb") as f:
                while chunk := f.read(CHUNK):
                    h.update(chunk)
        except OSError:
            return None
        return cls(root, h.hexdigest())

    def copy_into(self, folder: Path, dsm: Path) -> bool:
        """Copy the entry's tiles and tiles.json into ``folder`` (tiles.json naming ``dsm`` as its source); False
        (``folder`` left without tiles) when there is no entry or it cannot be read."""
        try:
            meta = json.loads((self.entry / "tiles.json").read_text())
            shutil.copytree(self.entry / "tiles", folder / "tiles", copy_function=shutil.copyfile)
        except (OSError, ValueError):
            shutil.rmtree(folder / "tiles", ignore_errors=True)
            return False
        meta["source"]["file"] = str(dsm)
        write_json(folder / "tiles.json", meta)
        log.info("terrain: tiles of %s taken from the conversion cache (%s)", dsm.name, self.entry)
        return True

    def store(self, folder: Path) -> dict[str, Any]:
        """Keep ``folder``'s tiles and tiles.json (a conversion just written there) as the entry; returns what the
        conversion's manifest says of the cache (``tiles_cache``: the key, not a hit)."""
        note = {"key": self.key, "hit": False}
        if self.entry.is_dir():
            return note
        tmp = self.entry.parent / f".{self.key}.tmp-{os.getpid()}"
        try:
            self.entry.parent.mkdir(parents=True, exist_ok=True)
            shutil.rmtree(tmp, ignore_errors=True)
            shutil.copytree(folder / "tiles", tmp / "tiles", copy_function=shutil.copyfile)
            shutil.copyfile(folder / "tiles.json", tmp / "tiles.json")
            os.rename(tmp, self.entry)
        except OSError as exc:  # another process stored it first, or the cache is not writable
            log.debug("terrain cache: cannot store %s: %s", self.entry, exc)
            shutil.rmtree(tmp, ignore_errors=True)
        return note
