"""What vinecli may write where: ``--out`` holds only what vinecli made, never an input.

* Every folder vinecli creates carries a marker: the vinecli ``manifest.json`` every output folder gets
  last (a run, a world, a report, terrain), or, on the folders that hold outputs (a runs folder,
  ``_worlds``), the marker file :data:`MARKER` (``.vinecli``: the tool, what the folder is, the version).
  ``--overwrite`` and ``run batch`` replace only a marked folder, and only when it holds nothing but what
  its manifest lists (:func:`replaceable_problem`); a user's file or folder in the way is named and kept
  (OutputError, exit 2).
* Paths built from names stay inside their root and never pass through a symbolic link below it
  (:func:`contained_path`): a ``_worlds`` link planted in ``--out`` cannot send a write elsewhere.
* An output may not be, contain or lie inside an input of the command (:mod:`vinecli.inputs`).
"""

from __future__ import annotations

import errno
import json
import os
import secrets
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from vinecli import __version__
from vinecli.errors import OutputError
from vinecli.inputs import current_inputs

__all__ = [
    "MANIFEST", "MARKER", "check_output_file", "check_output_target", "contained_path", "is_vinecli_dir",
    "make_unique_dir", "replaceable_problem", "write_marker",
]

#: the file every output directory gets last (what was read, configured and written)
MANIFEST = "manifest.json"
#: the marker every folder vinecli creates carries
MARKER = ".vinecli"


def write_marker(folder: Path, kind: str) -> None:
    """Mark ``folder`` as made by vinecli (``kind``: run, world, report, runs, terrain...)."""
    (Path(folder) / MARKER).write_text(json.dumps({"tool": "vinecli", "kind": kind, "version": __version__}) + "\n",
                                       encoding="utf-8")


def _manifest(folder: Path) -> dict[str, Any] | None:
    """The vinecli ``manifest.json`` of ``folder``, or None (none, unreadable or not vinecli's)."""
    try:
        doc = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) and doc.get("tool") == "vinecli" else None


def _listed_outputs(doc: dict[str, Any] | None) -> list[str] | None:
    """The output paths a vinecli manifest ``doc`` lists, or None (no manifest, or not a list of outputs)."""
    try:
        return None if doc is None else [str(e["path"]) for e in doc.get("outputs", [])]
    except (KeyError, TypeError, AttributeError):
        return None


def command_kind(command: str) -> str:
    """What kind of folder a command writes: its first two words ("run mission", "terrain convert", ...)."""
    return " ".join(str(command).split()[:2])


def is_vinecli_dir(folder: str | Path) -> bool:
    """Did vinecli make ``folder`` (a real folder, not a link, with the marker or a vinecli manifest)?"""
    p = Path(folder)
    if p.is_symlink() or not p.is_dir():
        return False
    return (p / MARKER).is_file() or _listed_outputs(_manifest(p)) is not None


def replaceable_problem(folder: Path, kind: str | None = None) -> str | None:
    """Why ``folder`` must not be replaced (it is not vinecli's, holds a user's file, or was written by another
    command than ``kind``), or None.

    A marked folder with a manifest may hold only what the manifest lists (and the ``.aux.xml`` GDAL writes
    beside a GeoTIFF it opened, the manifests of nested steps in its folders, and empty folders); a marked folder
    without one (a runs folder) may not be replaced at all. With ``kind`` (a command, :func:`command_kind`), only
    a folder that command wrote: a mistyped ``--out`` of ``plan swath`` cannot replace a run.
    """
    if folder.is_symlink():
        return "is a symbolic link, not a folder vinecli made (kept)"
    if not is_vinecli_dir(folder):
        return "is not a folder vinecli made (no .vinecli marker; kept)"
    doc = _manifest(folder)
    listed = _listed_outputs(doc)
    if doc is None or listed is None:
        return "is a vinecli folder that holds other outputs (kept)"
    made_by = command_kind(str(doc.get("command", "")))
    if kind is not None and made_by != command_kind(kind):
        return f"was written by 'vinecli {made_by}', not 'vinecli {command_kind(kind)}' (kept; choose another output)"
    files = set(listed) | {MANIFEST, MARKER} | {f + ".aux.xml" for f in listed}  # + GDAL's sidecars of ours
    dirs = {parent.as_posix() for f in listed for parent in Path(f).parents}
    files |= {f"{d}/{MANIFEST}" for d in dirs if d != "."}  # the manifest a nested step wrote (terrain convert)
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder).as_posix()
        if p.is_dir() and not p.is_symlink() and rel not in dirs and not any(p.iterdir()):
            continue  # an empty folder (a flat world's terrain/) holds nothing to lose
        if p.is_symlink() or (rel not in dirs if p.is_dir() else rel not in files):
            return f"holds {rel}, which vinecli did not write (kept; move it away first)"
    return None


def contained_path(root: Path, *parts: str) -> Path:
    """``root/parts...``, proven to stay strictly inside ``root`` without passing through a symbolic link
    below it (an existing component that is a link is refused), so a write there cannot land elsewhere.

    OutputError (exit 2) otherwise: the one guard every run, case, world and page path goes through.
    ``root`` itself may be a link (the user chose it).
    """
    root = Path(root)
    target = root.joinpath(*parts)
    base = root.resolve()
    cur = root
    for part in Path(*parts).parts if parts else ():
        cur = cur / part
        if cur.is_symlink():
            raise OutputError(f"refusing to write through the symbolic link {cur} (kept)", path=target)
    resolved = target.resolve()
    if resolved == base or not resolved.is_relative_to(base):
        raise OutputError(f"refusing to write outside the output directory {root}", path=target)
    return target


def _refuse_inputs(out: Path, inputs: Iterable[str | Path]) -> None:
    from vinecli.inputs import InputSet

    extra = InputSet()
    for inp in inputs:
        extra.add(inp)
    extra.refuse(out)
    current = current_inputs()
    if current is not None:
        current.refuse(out)


def _probe_writable(out: Path) -> None:
    probe = out.resolve().parent
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"output location is not writable ({probe} is not a directory)", path=out)
    try:
        make_unique_dir(probe, ".vinecli-probe-").rmdir()
    except OSError as exc:
        raise OutputError(f"output location is not writable ({exc.strerror})", path=out) from None


def check_output_target(out: Path, *, overwrite: bool = False, inputs: Iterable[str | Path] = (),
                        kind: str | None = None) -> None:
    """Fail early (OutputError, exit 2), before any heavy work, if the folder ``out`` cannot or must not be
    written.

    Refused: ``out`` is, contains or lies inside an input (``inputs`` and those of the running command,
    :mod:`vinecli.inputs`); ``out`` is a symbolic link or exists and is not a folder; it exists non-empty
    without ``overwrite``, or with ``overwrite`` but is not a folder vinecli made holding only its outputs
    (by the command ``kind``, when given: :func:`replaceable_problem`); its nearest existing ancestor is not writable (probed for real, which
    catches read-only file systems and mounts where ``os.access`` says yes).
    """
    out = Path(out)
    _refuse_inputs(out, inputs)
    if out.is_symlink():
        raise OutputError("is a symbolic link; give the folder itself (kept)", path=out)
    if out.exists() and not out.is_dir():
        raise OutputError("exists and is not a directory (kept)", path=out)
    if out.exists() and any(out.iterdir()):
        if not overwrite:
            raise OutputError("output directory exists and is not empty (use --overwrite)", path=out)
        problem = replaceable_problem(out, kind)
        if problem is not None:
            raise OutputError(problem, path=out)
    _probe_writable(out)


def check_output_file(path: Path, *, overwrite: bool = False, inputs: Iterable[str | Path] = ()) -> None:
    """Fail early (OutputError, exit 2) if the file ``path`` cannot or must not be written: it is, contains
    or lies inside an input, it is a symbolic link or not a regular file, it exists without ``overwrite``,
    or its folder is not writable."""
    path = Path(path)
    _refuse_inputs(path, inputs)
    if path.is_symlink():
        raise OutputError("is a symbolic link (kept)", path=path)
    if path.exists():
        if not path.is_file():
            raise OutputError("exists and is not a regular file (kept)", path=path)
        if not overwrite:
            raise OutputError("exists (kept; use --overwrite to replace it)", path=path)
    _probe_writable(path)


def make_unique_dir(parent: Path, prefix: str) -> Path:
    """Create a new, uniquely named directory in ``parent`` with the umask's permissions (not mkdtemp's 0700)."""
    for _ in range(100):
        d = parent / f"{prefix}{os.getpid()}-{secrets.token_hex(4)}"
        try:
            d.mkdir(mode=0o777)
        except FileExistsError:
            continue
        return d
    raise FileExistsError(errno.EEXIST, "no free temporary name", str(parent))
