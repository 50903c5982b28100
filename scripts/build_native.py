"""Compile the per-step kernel (vinecli/native.py KERNEL) with mypyc, ahead of time.

    .venv/bin/python scripts/build_native.py            # in place: `make native` runs this when a kernel source changed
    python scripts/build_native.py --out DIR            # into DIR/vinecli/ (the wheel's build hook, hatch_build.py)

Writes ``<module>.cpython-*.so`` (and its ``<module>__mypyc`` library) beside each source, or under
``DIR/vinecli/``, and, last, ``native.json`` (the digest of every source it compiled, the compiler and the C
flags); until that manifest exists and matches its sources, vinecli runs the sources. A failed build prints the
end of its log (mypyc's and the C compiler's messages) and exits 1.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import sys
import time
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


@contextlib.contextmanager
def _output_to(log: Path) -> Iterator[None]:
    """Send this process's stdout and stderr, and its children's (gcc), to ``log``."""
    log.parent.mkdir(parents=True, exist_ok=True)
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with log.open("w") as f:
        os.dup2(f.fileno(), 1)
        os.dup2(f.fileno(), 2)
        try:
            yield
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])


def build(out: Path | None) -> int:
    """Compile the kernel in place (``out`` None: ``make native``) or into ``out/vinecli/`` (the wheel's build
    hook); the manifest names which. 0 when built, 1 when it failed (the log's end on stderr)."""
    how = "make native" if out is None else "wheel"
    os.chdir(REPO)
    sys.path.insert(0, str(REPO))
    os.environ["VINECLI_PURE_PYTHON"] = "1"  # importing vinecli here must not load an old kernel
    work = REPO / "build" / "native" if out is None else out / "_build"
    shutil.rmtree(work, ignore_errors=True)  # no incremental state: mypyc's cache has failed on edited classes
    os.environ["MYPY_CACHE_DIR"] = str(work / "mypy-cache")
    from vinecli import native

    manifest = native.MANIFEST if out is None else out / "vinecli" / native.MANIFEST.name
    manifest.unlink(missing_ok=True)  # a failed build leaves no manifest: the sources run
    from mypy.version import __version__ as mypy_version
    from mypyc.build import mypycify
    from setuptools import setup

    t0 = time.perf_counter()
    paths = [f"vinecli/{rel}" for rel in native.KERNEL]
    log = work / "build.log"
    print(f"compiling the per-step kernel ({len(paths)} modules) with mypyc, ~1 min; log: {log}", flush=True)
    where = ["--inplace"] if out is None else ["--build-lib", str(out)]
    try:
        with _output_to(log):  # mypyc's notes, setuptools' and gcc's output: only shown when the build fails
            exts = mypycify(paths, opt_level="3", separate=True, target_dir=str(work / "c"))
            for ext in exts:  # the floating-point contract of the pure-Python loop: no fused multiply-add
                ext.extra_compile_args = [*ext.extra_compile_args, *native.CFLAGS]
            setup(name="vinecli-kernel", packages=[], py_modules=[], ext_modules=exts,
                  script_args=["-q", "build_ext", *where, "--build-temp", str(work / "obj"),
                               "-j", str(os.cpu_count() or 1)])
    except (Exception, SystemExit):  # noqa: BLE001 - whatever failed, the log says why
        print("".join(log.read_text(errors="replace").splitlines(keepends=True)[-40:]), file=sys.stderr)
        print(f"kernel build failed (whole log: {log})", file=sys.stderr)
        return 1
    doc = {"compiler": f"mypyc {mypy_version}", "python": sys.version.split()[0], "cflags": list(native.CFLAGS),
           "build": how, "sources": native.source_digests()}
    manifest.parent.mkdir(parents=True, exist_ok=True)
    tmp = manifest.with_suffix(".tmp")
    tmp.write_text(json.dumps(doc, indent=1) + "\n")
    tmp.replace(manifest)
    print(f"compiled {len(paths)} kernel modules with mypyc in {time.perf_counter() - t0:.0f} s")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=None, help="build into OUT/vinecli/ instead of in place")
    args = ap.parse_args()
    status = build(args.out.resolve() if args.out else None)
    if status and args.out is None:
        print("vinecli still runs, on the pure-Python sources", file=sys.stderr)
    return status


if __name__ == "__main__":
    raise SystemExit(main())
