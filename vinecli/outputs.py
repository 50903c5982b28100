"""Atomic output directories with a ``manifest.json``.

Every command writes its results through :func:`atomic_output_dir`: files go to a hidden
temporary sibling directory, the manifest is written last, and the directory is renamed
into place only when everything succeeded. On any error the temporary directory is
removed, so a failed command leaves nothing half-written in ``--out``.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator, Mapping
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vinecli import __version__
from vinecli.errors import OutputError


def sha256_file(path: Path, chunk: int = 1 << 20) -> str:
    """Hex sha256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk):
            h.update(block)
    return h.hexdigest()


def write_json(path: Path, data: Any) -> None:
    """Write ``data`` as indented UTF-8 JSON (NaN is written as null)."""
    path.write_text(json.dumps(_jsonable(data), indent=2, allow_nan=False) + "\n", encoding="utf-8")


def _jsonable(obj: Any) -> Any:
    """Recursively convert numpy scalars/arrays, Paths and non-finite floats to JSON types."""
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "tolist"):  # numpy scalar or array
        return _jsonable(obj.tolist())
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
            if p.is_file() and p.name != "manifest.json":
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


def check_output_target(out: Path, *, overwrite: bool = False) -> None:
    """Fail early (exit 2) if ``out`` cannot be created: exists as a non-empty dir, or parent not writable."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputError("exists and is not a directory", path=out)
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise OutputError("output directory exists and is not empty (use --overwrite)", path=out)
    parent = out.resolve().parent
    probe = parent
    while not probe.exists():
        probe = probe.parent
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError("output location is not writable", path=out)


@contextmanager
def atomic_output_dir(out: Path, manifest: Manifest, *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary directory; on success write ``manifest.json`` and rename it to ``out``.

    On any exception the temporary directory is deleted and ``out`` is left untouched.
    """
    out = Path(out)
    check_output_target(out, overwrite=overwrite)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=out.parent))
    except OSError as exc:
        raise OutputError(f"cannot create output directory ({exc.strerror})", path=out) from exc
    try:
        yield tmp
        write_json(tmp / "manifest.json", manifest.to_dict(tmp))
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
