"""Atomic output directories with a ``manifest.json``.

Every command writes its results through :func:`atomic_output_dir`: files go to a hidden
temporary sibling directory, the manifest is written last, and the directory is renamed
into place only when everything succeeded. On any error the temporary directory is
removed, so a failed command leaves nothing half-written in ``--out``.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import platform
import secrets
import shutil
import sys
import time
from collections.abc import Iterable, Iterator, Mapping
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vinecli import __version__
from vinecli.errors import OutputError

#: the file every output directory gets last (what was read, configured and written)
MANIFEST = "manifest.json"


def sha256_file(path: Path, chunk: int = 1 << 20) -> str:
    """Hex sha256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk):
            h.update(block)
    return h.hexdigest()


def write_json(path: Path, data: Any) -> None:
    """Write ``data`` as indented UTF-8 JSON (NaN is written as null)."""
    path.write_text(json.dumps(jsonable(data), indent=2, allow_nan=False) + "\n", encoding="utf-8")


def write_text_atomic(path: Path | str, text: str) -> None:
    """Write ``text`` (UTF-8) to the file ``path`` atomically: a temporary sibling, then a rename.

    On an OSError the temporary file is removed and OutputError (exit 2, ``cannot write: ...``) is
    raised; ``path`` is then left as it was.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputError(f"cannot write: {exc.strerror}", path=path) from None


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


def contained_path(root: Path, *parts: str) -> Path:
    """``root/parts...``, proven (after resolving symlinks and ``..``) to stay strictly inside ``root``.

    OutputError (exit 2) otherwise: the one guard every run, case and page path goes through.
    """
    root = Path(root)
    target = root.joinpath(*parts)
    base = root.resolve()
    resolved = target.resolve()
    if resolved == base or not resolved.is_relative_to(base):
        raise OutputError(f"refusing to write outside the output directory {root}", path=target)
    return target


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


def check_output_target(out: Path, *, overwrite: bool = False, inputs: Iterable[str | Path] = ()) -> None:
    """Fail early (OutputError, exit 2), before any heavy work, if ``out`` cannot or must not be written.

    Refused: ``out`` exists and is not a directory, exists non-empty without ``overwrite``, equals or
    contains one of ``inputs`` (replacing it would delete the input), or its nearest existing ancestor
    is not writable. Writability is probed for real (a directory is created and removed there), which
    catches read-only file systems and mounts where ``os.access`` says yes.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputError("exists and is not a directory", path=out)
    resolved = out.resolve()
    for inp in inputs:
        rin = Path(inp).resolve()
        if rin == resolved or rin.is_relative_to(resolved):
            raise OutputError(f"the output directory would replace the input {inp}", path=out)
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise OutputError("output directory exists and is not empty (use --overwrite)", path=out)
    probe = resolved.parent
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"output location is not writable ({probe} is not a directory)", path=out)
    try:
        _make_unique_dir(probe, ".vinecli-probe-").rmdir()
    except OSError as exc:
        raise OutputError(f"output location is not writable ({exc.strerror})", path=out) from None


def _make_unique_dir(parent: Path, prefix: str) -> Path:
    """Create a new, uniquely named directory in ``parent`` with the umask's permissions (not mkdtemp's 0700)."""
    for _ in range(100):
        d = parent / f"{prefix}{os.getpid()}-{secrets.token_hex(4)}"
        try:
            d.mkdir(mode=0o777)
        except FileExistsError:
            continue
        return d
    raise FileExistsError(errno.EEXIST, "no free temporary name", str(parent))


@contextmanager
def atomic_output_dir(out: Path, manifest: Manifest, *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary directory; on success write ``manifest.json`` and rename it to ``out``.

    On any exception the temporary directory is deleted and ``out`` is left untouched. ``out`` may not
    equal or contain one of ``manifest.inputs`` (see :func:`check_output_target`). Directories are
    created with the process umask.
    """
    out = Path(out)
    check_output_target(out, overwrite=overwrite, inputs=manifest.inputs)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = _make_unique_dir(out.parent, f".{out.name}.tmp-")
    except OSError as exc:
        raise OutputError(f"cannot create output directory ({exc.strerror})", path=out) from exc
    try:
        yield tmp
        write_json(tmp / MANIFEST, manifest.to_dict(tmp))
        if out.exists():
            old = out.with_name(f".{out.name}.old-{os.getpid()}")
            out.rename(old)
            tmp.rename(out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
