"""The wheel that ``pip install .`` / ``pip wheel .`` builds carries the compiled kernel (hatch_build.py).

The build hook packages a current in-place build as built (``make test`` has just made it), so these build in
seconds; a tree without one compiles in the hook (``scripts/build_native.py --out``, the same code and C flags
as ``make native``: BENCHMARKS.md records a fresh-venv ``pip install .``). An installed wheel must run its own
extensions, not the tree's sources.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

from repo_paths import REPO

from vinecli import native


def _wheel(out: Path, **env: str) -> Path:
    subprocess.run([sys.executable, "-m", "pip", "wheel", str(REPO), "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(out)], env={**os.environ, **env}, check=True, capture_output=True, text=True)
    (whl,) = out.glob("vinecli-*.whl")
    return whl


def test_the_wheel_carries_the_compiled_kernel_and_runs_it(tmp_path: Path) -> None:
    assert native.build_is_current(), "the compiled kernel is missing or stale: run `make native`"
    whl = _wheel(tmp_path / "dist")
    assert "-cp3" in whl.name and "linux" in whl.name, whl.name  # a platform wheel, not py3-none-any
    names = set(zipfile.ZipFile(whl).namelist())
    for rel in native.KERNEL:
        mod = rel.removesuffix(".py")
        assert any(n.startswith(f"vinecli/{mod}.cpython-") for n in names), rel
        assert any(n.startswith(f"vinecli/{mod}__mypyc.cpython-") for n in names), rel
    built = json.loads(zipfile.ZipFile(whl).read("vinecli/native.json"))
    assert built["cflags"] == list(native.CFLAGS) and built["compiler"].startswith("mypyc")

    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(site), str(whl)],
                   check=True, capture_output=True, text=True)
    probe = ("import json, vinecli.native as n, vinecli.sim.loop as l; "
             "print(json.dumps([n.state, n.is_compiled(l), l.__file__, n.identity()]))")
    env = {**os.environ, "PYTHONPATH": str(site), native.PURE_ENV: "0"}
    out = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path, env=env, check=True, capture_output=True,
                         text=True)
    state, compiled, path, ident = json.loads(out.stdout)
    assert (state, compiled) == ("compiled", True) and path.startswith(str(site)), out.stdout
    assert ident["kind"] == "compiled" and ident["cflags"] == list(native.CFLAGS)
    assert ident["sources_sha256"] == native.identity()["sources_sha256"]  # the tree's kernel sources


def test_a_pure_python_wheel_only_on_request(tmp_path: Path) -> None:
    whl = _wheel(tmp_path, VINECLI_BUILD_KERNEL="0")
    assert whl.name.endswith("-py3-none-any.whl"), whl.name
    names = zipfile.ZipFile(whl).namelist()
    assert not [n for n in names if n.endswith(".so") or n == "vinecli/native.json"]
    assert "vinecli/sim/loop.py" in names
