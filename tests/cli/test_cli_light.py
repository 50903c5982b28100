"""``vinecli --help`` stays fast: the command modules and vinecli/cli/options.py take their defaults from light
library modules only (no numpy, pydantic, rasterio, pybullet at import)."""

from __future__ import annotations

import subprocess
import sys

from tests.repo_paths import REPO


def test_the_cli_imports_no_heavy_library() -> None:
    code = ("import sys, vinecli.cli.app; "
            "print(sorted(m for m in ('numpy', 'pydantic', 'rasterio', 'pybullet', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(REPO), "PATH": ""})
    assert out.stdout.strip() == "[]"
