"""Atomic output directories with a ``manifest.json``, locked and marked (docs/architecture.md
"Inputs, names and outputs").

Every command writes its results through :func:`atomic_output_dir`: it holds the output's lock
(:func:`vinecli.locks.output_lock`: a second writer exits 2, ``in use by pid N``), files go to a hidden
temporary sibling directory, the manifest (which marks the folder as vinecli's) is written last, and the
directory is swapped into place in one step (``renameat2(RENAME_EXCHANGE)`` where the kernel has it, SIGINT/SIGTERM
held back for the moment of the swap) only when everything succeeded. On any error the temporary
directory is removed, so a failed or interrupted command leaves nothing half-written in ``--out``;
temporary siblings left by a process that was killed (``kill -9``) are removed by the next writer of the
same output. Single files go through :func:`write_text_atomic`. What may be written where (markers,
inputs, links) is :mod:`vinecli.output_guard`'s.
"""

from __future__ import annotations

import contextlib
import ctypes
import hashlib
import json
import os
import platform
import re
import secrets
import shutil
import signal
import sys
import threading
import time
from collections.abc import Iterator, Mapping
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vinecli import __version__
from vinecli.errors import OutputError
from vinecli.inputs import current_inputs
from vinecli.lifeline import pid_alive
from vinecli.locks import output_lock, remove_if_free
from vinecli.output_guard import (
    MANIFEST,
    MARKER,
    check_output_file,
    check_output_target,
    contained_path,
    make_unique_dir,
    write_marker,
)

__all__ = [
    "MANIFEST", "MARKER", "Manifest", "atomic_file", "atomic_output_dir", "check_output_file",
    "check_output_target", "write_bytes_atomic",
    "contained_path", "json_text", "jsonable", "manifest_problem", "output_folder", "remove_stale_temps", "sha256_file",
    "timed_stage", "write_json", "write_text_atomic",
]


def sha256_file(path: Path, chunk: int = 1 << 20) -> str:
    """Hex sha256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk):
            h.update(block)
    return h.hexdigest()


def json_text(data: Any) -> str:
    """``data`` as indented JSON text with a final newline (NaN is written as null)."""
    return json.dumps(jsonable(data), indent=2, allow_nan=False) + "\n"


def write_json(path: Path, data: Any) -> None:
    """Write ``data`` as indented UTF-8 JSON (:func:`json_text`)."""
    path.write_text(json_text(data), encoding="utf-8")


def write_text_atomic(path: Path | str, text: str) -> None:
    """Write ``text`` (UTF-8) to the file ``path`` atomically (:func:`write_bytes_atomic`)."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_bytes_atomic(path: Path | str, data: bytes) -> None:
    """Write ``data`` to the file ``path`` atomically (:func:`atomic_file`)."""
    with atomic_file(path) as tmp:
        tmp.write_bytes(data)


@contextmanager
def atomic_file(path: Path | str, suffix: str = "") -> Iterator[Path]:
    """A temporary sibling of the file ``path`` for the block to write (``.NAME.tmp-<pid>-<8 random hex
    digits>`` + ``suffix``, e.g. ``.gpkg`` for a driver that goes by the extension: never a user's file, never
    another writer's), renamed to ``path`` when the block succeeds and removed when it fails; ``path`` is then
    left as it was. A symbolic link or a non-file at ``path`` is refused, never followed; an input of the running
    command is refused. An OSError becomes OutputError (exit 2, ``cannot write: ...``)."""
    path = Path(path)
    inputs = current_inputs()
    if inputs is not None:
        inputs.refuse(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}-{secrets.token_hex(4)}{suffix}")
    try:
        yield tmp
        if path.is_symlink() or (path.exists() and not path.is_file()):
            raise OutputError("is a symbolic link or not a regular file (kept)", path=path)
        with _signals_held():
            os.replace(tmp, path)
    except OSError as exc:
        raise OutputError(f"cannot write: {exc.strerror}", path=path) from None
    finally:
        tmp.unlink(missing_ok=True)


def jsonable(obj: Any) -> Any:
    """Recursively convert numpy scalars/arrays, Paths and non-finite floats to JSON types."""
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "tolist"):  # numpy scalar or array
        return jsonable(obj.tolist())
    if isinstance(obj, float) and (obj != obj or obj in (float("inf"), float("-inf"))):
        return None
    return obj


@contextmanager
def timed_stage(seconds: dict[str, float], name: str, digits: int = 6) -> Iterator[None]:
    """Add the wall-clock seconds of the ``with`` block to ``seconds[name]`` (rounded to ``digits``)."""
    t0 = time.perf_counter()
    try:
        yield
    finally:
        seconds[name] = round(seconds.get(name, 0.0) + time.perf_counter() - t0, digits)


@dataclass
class Manifest:
    """What a command read, how it was configured and what it wrote.

    ``timings`` are wall-clock seconds per named stage.
    """

    command: str
    parameters: dict[str, Any] = field(default_factory=dict)
    inputs: list[Path] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)

    def stage(self, name: str) -> AbstractContextManager[None]:
        """Time a named stage into ``timings`` (seconds)."""
        return timed_stage(self.timings, name)

    def to_dict(self, root: Path) -> dict[str, Any]:
        """Manifest as a JSON-able dict; outputs are every file under ``root`` with hashes."""
        outputs = []
        for p in sorted(root.rglob("*")):
            if p.is_file() and p.name != MANIFEST:
                outputs.append({"path": p.relative_to(root).as_posix(), "bytes": p.stat().st_size,
                                "sha256": sha256_file(p)})
        inputs = []
        for p in self.inputs:
            p = Path(p)
            entry: dict[str, Any] = {"path": str(p)}
            if p.is_file():
                entry.update(bytes=p.stat().st_size, sha256=sha256_file(p))
            inputs.append(entry)
        return {
            "tool": "vinecli",
            "version": __version__,
            "command": self.command,
            "python": sys.version.split()[0],
            "platform": platform.platform(),
            "created_unix": round(time.time(), 3),
            "parameters": self.parameters,
            "inputs": inputs,
            "outputs": outputs,
            "timings_s": self.timings,
            **self.extra,
        }


def manifest_problem(root: Path) -> str | None:
    """Why the directory ``root`` does not hold exactly what its ``manifest.json`` lists, or None.

    Every listed output must exist inside ``root`` with the recorded size and sha256 (a truncated or
    rewritten file is caught); a missing or unreadable manifest is a problem too.
    """
    root = Path(root)
    try:
        outputs = json.loads((root / MANIFEST).read_text(encoding="utf-8"))["outputs"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return f"no readable manifest.json ({type(exc).__name__})"
    for entry in outputs:
        try:
            p = contained_path(root, entry["path"])
            if not p.is_file():
                return f"{entry['path']} is missing"
            if p.stat().st_size != int(entry["bytes"]) or sha256_file(p) != entry["sha256"]:
                return f"{entry['path']} does not match its manifest hash"
        except (OutputError, OSError, KeyError, TypeError, ValueError) as exc:
            return f"bad manifest entry {entry!r} ({type(exc).__name__})"
    return None


_LEFTOVER_RE = re.compile(r"\.(?P<name>.+)\.(?:(?:tmp|old)-(?P<pid>\d+)(?:-[0-9a-f]+)?|lock)")


def remove_stale_temps(folder: Path, name: str | None = None) -> list[Path]:
    """Remove what killed writers left in ``folder``: temporary siblings (``.NAME.tmp-PID-...``,
    ``.NAME.old-PID``) whose process is dead and lock files (``.NAME.lock``) no process holds; only those of
    ``NAME`` = ``name`` when given. Returns what was removed."""
    folder = Path(folder)
    removed: list[Path] = []
    if not folder.is_dir():
        return removed
    for p in folder.glob(f".{name}.*" if name is not None else ".*"):
        m = _LEFTOVER_RE.fullmatch(p.name)
        if m is None or (name is not None and m["name"] != name):
            continue
        if m["pid"] is None:
            if remove_if_free(p):
                removed.append(p)
            continue
        if int(m["pid"]) == os.getpid() or pid_alive(int(m["pid"])):
            continue
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
        removed.append(p)
    return removed


_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Swap the names ``a`` and ``b`` atomically (Linux renameat2 RENAME_EXCHANGE); False when unsupported."""
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    rc = fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    return rc == 0


@contextmanager
def _signals_held() -> Iterator[None]:
    """Hold SIGINT/SIGTERM back (main thread) for a few system calls that must not be split by a signal."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _commit(tmp: Path, out: Path) -> None:
    """Put the finished ``tmp`` at ``out``: one atomic step, the replaced folder removed after."""
    with _signals_held():
        if not out.exists():
            tmp.rename(out)
            return
        if _exchange(tmp, out):
            old = tmp
        else:
            old = out.with_name(f".{out.name}.old-{os.getpid()}")
            out.rename(old)
            tmp.rename(out)
    shutil.rmtree(old, ignore_errors=True)


@contextmanager
def atomic_output_dir(out: Path, manifest: Manifest, *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary directory; on success write ``manifest.json`` (the folder's vinecli marker) and swap it
    in at ``out``.

    Holds ``out``'s lock (a second writer: OutputError ``in use by pid N``, exit 2) from the checks to
    the swap. On any exception the temporary directory is deleted and ``out`` is left untouched. ``out``
    may not be, contain or lie inside an input (``manifest.inputs`` and the command's,
    :mod:`vinecli.inputs`), and is replaced only when the same command (``manifest.command``) made it and it
    holds only its outputs (:func:`check_output_target`, run again just before the swap). Directories follow the umask.
    """
    out = Path(out)
    check_output_target(out, overwrite=overwrite, inputs=manifest.inputs, kind=manifest.command)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create output directory ({exc.strerror})", path=out) from exc
    with output_lock(out):
        remove_stale_temps(out.parent, out.name)
        try:
            tmp = make_unique_dir(out.parent, f".{out.name}.tmp-")
        except OSError as exc:
            raise OutputError(f"cannot create output directory ({exc.strerror})", path=out) from exc
        try:
            yield tmp
            write_json(tmp / MANIFEST, manifest.to_dict(tmp))
            check_output_target(out, overwrite=overwrite, inputs=manifest.inputs, kind=manifest.command)
            _commit(tmp, out)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise


@contextmanager
def output_folder(folder: Path, kind: str) -> Iterator[Path]:
    """Make sure the folder outputs go into exists (created with its missing parents and marked ``kind`` when
    vinecli creates it); on an exception the folders this call created are removed again if they hold
    nothing but the marker, so a refused command leaves nothing behind."""
    folder = Path(folder)
    missing: list[Path] = []
    p = folder
    while not p.exists() and not p.is_symlink():
        missing.append(p)
        p = p.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create the output folder ({exc.strerror})", path=folder) from None
    if missing:
        write_marker(folder, kind)
    try:
        yield folder
    except BaseException:
        for d in missing:  # deepest first
            with contextlib.suppress(OSError):
                if {c.name for c in d.iterdir()} <= {MARKER}:
                    (d / MARKER).unlink(missing_ok=True)
                    d.rmdir()
        raise
