"""References from one spec to another: resolved relative to the file that names them, confined (a
``base: /etc/shadow`` is refused unread).

A spec names other specs: ``base:`` (any spec), ``vehicle:`` (missions and worlds), the missions and
world specs of a pipeline. :func:`spec_reference` resolves such a reference relative to the folder of
the file that names it and accepts it only when it is a YAML spec (``.yaml``/``.yml``, a regular file)
inside an allowed folder:

* the folder of the file that names it, and below;
* the working directory, and below;
* vinecli's shipped specs (``vehicles/``, ``worlds/``, ``pipelines/`` next to the package);
* the folders listed in ``VINECLI_SPEC_ROOTS`` (separated like ``PATH``).

Anything else (``base: /etc/shadow``, ``vehicle: ../../../secret.yaml``) is refused with exit 2 before it
is opened, so no part of its content can reach an error message. Data files a spec names (a DSM, a
terrain folder, a PX4 binary) are not specs: they are checked by their readers (regular files only,
:mod:`vinecli.inputs`).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import vinecli
from vinecli.errors import SpecError
from vinecli.inputs import file_kind

__all__ = ["ROOTS_ENV", "SPEC_SUFFIXES", "allowed_roots", "spec_reference"]

SPEC_SUFFIXES = (".yaml", ".yml")
ROOTS_ENV = "VINECLI_SPEC_ROOTS"
_SHIPPED = [Path(vinecli.__file__).resolve().parents[1] / d for d in ("vehicles", "worlds", "pipelines")]


def allowed_roots(naming_file: Path) -> list[Path]:
    """Folders a reference from ``naming_file`` may point into (see the module docstring)."""
    extra = [Path(p).resolve() for p in os.environ.get(ROOTS_ENV, "").split(os.pathsep) if p]
    return [naming_file.resolve().parent, Path.cwd().resolve(), *_SHIPPED, *extra]


def spec_reference(ref: str, naming_file: Path, what: str, *, try_suffix: bool = False) -> Path:
    """The spec file that ``ref`` names in ``naming_file`` (relative to its folder; with ``try_suffix``
    ``ref`` may leave out ``.yaml``), proven to be a ``.yaml``/``.yml`` regular file inside the allowed
    folders. SpecError (exit 2) naming ``naming_file`` and the field ``what`` otherwise; the target is never
    read here."""
    naming_file = Path(naming_file)
    raw = naming_file.parent / str(ref)
    candidates = [raw, raw.with_name(raw.name + ".yaml")] if try_suffix and raw.suffix not in SPEC_SUFFIXES else [raw]
    roots = allowed_roots(naming_file)
    for cand in candidates:
        resolved = cand.resolve()
        if not any(resolved.is_relative_to(r) for r in roots):
            raise SpecError(f"{what}: {str(ref)!r} lies outside the folders specs may refer to (the file's own "
                            f"folder, the working directory, vinecli's shipped specs, {ROOTS_ENV})", path=naming_file)
        if resolved.suffix not in SPEC_SUFFIXES:
            continue
        try:
            mode = resolved.stat().st_mode
        except OSError:
            continue
        if not stat.S_ISREG(mode):
            raise SpecError(f"{what}: {str(ref)!r} is {file_kind(mode)}, not a regular file", path=naming_file)
        return resolved
    if raw.suffix not in SPEC_SUFFIXES and (raw.exists() or not try_suffix):
        raise SpecError(f"{what}: {str(ref)!r} is not a spec file ({'/'.join(SPEC_SUFFIXES)})", path=naming_file)
    raise SpecError(f"{what}: {str(ref)!r} not found next to the file", path=naming_file)
