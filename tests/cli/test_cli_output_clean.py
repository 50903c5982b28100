"""PyBullet's C-level prints (build time, argv[0]) must not leak into the CLI's output."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from repo_paths import REPO


def test_world_build_prints_no_pybullet_noise(tmp_path: Path) -> None:
    out = tmp_path / "w"
    r = subprocess.run(
        [sys.executable, "-m", "vinecli", "world", "build", str(REPO / "worlds/flat.yaml"), "--out", str(out)],
        capture_output=True, text=True, timeout=120, check=False,
    )
    assert r.returncode == 0, r.stderr
    both = r.stdout + r.stderr
    assert "pybullet build time" not in both
    assert "argv[0]" not in both
    assert (out / "world.json").is_file()
