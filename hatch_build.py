"""The wheel's build hook: the wheel carries the compiled per-step kernel (vinecli/native.py).

hatchling runs this for ``pip install .`` and ``pip wheel .``: it compiles the kernel with mypyc and the
kernel's C flags (``scripts/build_native.py --out``) and adds the extensions and ``vinecli/native.json`` to a
platform wheel. A tree whose in-place build (``make native``) is current for this Python is packaged as built.
When the compiler fails the install stops with mypyc's and the C compiler's messages; ``VINECLI_BUILD_KERNEL=0``
builds a pure-Python wheel on purpose (runs then say ``kernel.kind: pure`` in summary.json). Editable installs
(``make install``) build nothing here: ``make native`` compiles in place.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from types import ModuleType
from typing import Any

from hatchling.builders.hooks.plugin.interface import BuildHookInterface

OPT_OUT = "VINECLI_BUILD_KERNEL"


def _native(root: Path) -> ModuleType:
    """vinecli/native.py of the tree at ``root``, loaded alone (importing vinecli would need its dependencies)."""
    spec = importlib.util.spec_from_file_location("_vinecli_native_for_build", root / "vinecli" / "native.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def kernel_files(package_dir: Path, kernel: tuple[str, ...]) -> dict[str, str]:
    """The compiled kernel under ``package_dir`` (a built ``vinecli/``) for this Python: absolute path -> path
    in the wheel, the manifest last; empty when any module's extension is missing."""
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    files: dict[str, str] = {}
    for rel in kernel:
        for name in (rel.removesuffix(".py") + suffix, rel.removesuffix(".py") + "__mypyc" + suffix):
            path = package_dir / name
            if not path.is_file():
                return {}
            files[str(path)] = f"vinecli/{name}"
    files[str(package_dir / "native.json")] = "vinecli/native.json"
    return files


class KernelBuildHook(BuildHookInterface):  # type: ignore[type-arg]
    PLUGIN_NAME = "custom"
    _out: Path | None = None  # the compiler's output folder of this build, removed once the wheel is written

    def initialize(self, version: str, build_data: dict[str, Any]) -> None:
        if self.target_name != "wheel" or version == "editable":
            return
        if os.environ.get(OPT_OUT, "1") == "0":
            self.app.display_warning(f"vinecli: {OPT_OUT}=0: a pure-Python wheel, without the compiled kernel")
            return
        root = Path(self.root)
        native = _native(root)
        files = kernel_files(native.PACKAGE_DIR, native.KERNEL) if native.build_is_current() else {}
        if files:
            self.app.display_info("vinecli: packaging the compiled kernel this tree built (make native)")
        else:
            out = self._out = Path(tempfile.mkdtemp(prefix="vinecli-kernel-"))
            r = subprocess.run([sys.executable, str(root / "scripts" / "build_native.py"), "--out", str(out)],
                               cwd=root, check=False)
            files = kernel_files(out / "vinecli", native.KERNEL) if r.returncode == 0 else {}
            if not files:
                self.app.abort(f"vinecli: the compiled kernel did not build (the compiler's messages are above). "
                               f"To install vinecli without it (the pure-Python kernel, several times slower per "
                               f"step): {OPT_OUT}=0 pip install .")
        build_data["force_include"].update(files)
        build_data["pure_python"] = False
        build_data["infer_tag"] = True

    def finalize(self, version: str, build_data: dict[str, Any], artifact_path: str) -> None:
        if self._out is not None:
            shutil.rmtree(self._out, ignore_errors=True)
