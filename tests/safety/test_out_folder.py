"""``--out`` holds only what vinecli made. ``--overwrite`` and a batch replace only folders
vinecli made (marked: a vinecli manifest, or the ``.vinecli`` marker of the folders that hold outputs) and
only when they hold nothing else; a user's file or folder in the way is named and kept (exit 2); a symbolic
link inside ``--out`` is never followed for writing. On main a batch replaced a user folder named like a
case, and a ``_worlds`` link made it write outside ``--out``."""

from __future__ import annotations

import os
from pathlib import Path

from attack_kit import cli, error_line, fingerprint, mission
from repo_paths import REPO


def _pipeline(d: Path, world: Path | str, name: str = "quick") -> Path:
    mission(d, name)
    p = d / "p.yaml"
    p.write_text(f"name: p\nworld: {world}\nmissions: [{name}.yaml]\n")
    return p


def test_a_batch_keeps_a_user_folder_named_like_a_case(flat_world_dir: Path, tmp_path: Path) -> None:
    p = _pipeline(tmp_path, flat_world_dir)
    user = tmp_path / "runs" / "quick"
    user.mkdir(parents=True)
    (user / "notes.txt").write_text("my field notes\n")
    before = fingerprint(tmp_path / "runs")
    r = cli("run", "batch", p, "--out", tmp_path / "runs")
    assert r.exit_code == 2, r.output
    line = error_line(r)
    assert "quick" in line and "kept" in line
    assert fingerprint(tmp_path / "runs") == before  # the folder, its file, and nothing else written


def test_a_worlds_link_in_out_is_not_followed(tmp_path: Path) -> None:
    (tmp_path / "w.yaml").write_text((REPO / "worlds" / "flat.yaml").read_text())
    p = _pipeline(tmp_path, "w.yaml")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    runs = tmp_path / "runs"
    runs.mkdir()
    os.symlink(elsewhere, runs / "_worlds")
    r = cli("run", "batch", p, "--out", runs)
    assert r.exit_code == 2, r.output
    assert "link" in error_line(r)
    assert list(elsewhere.iterdir()) == []  # nothing written outside --out
    assert (runs / "_worlds").is_symlink()  # and the link is kept


def test_a_link_named_like_a_case_is_kept(flat_world_dir: Path, tmp_path: Path) -> None:
    p = _pipeline(tmp_path, flat_world_dir)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "data.txt").write_text("keep\n")
    runs = tmp_path / "runs"
    runs.mkdir()
    os.symlink(elsewhere, runs / "quick")
    before = fingerprint(elsewhere, runs)
    r = cli("run", "batch", p, "--out", runs)
    assert r.exit_code == 2, r.output
    assert fingerprint(elsewhere, runs) == before


def test_overwrite_keeps_a_user_folder_named_like_the_run(flat_world_dir: Path, tmp_path: Path) -> None:
    m = mission(tmp_path, "m")
    user = tmp_path / "runs" / "m-s0"
    user.mkdir(parents=True)
    (user / "thesis.tex").write_text("\\chapter{Results}\n")
    before = fingerprint(user)
    r = cli("run", "mission", m, "--world", flat_world_dir, "--out", tmp_path / "runs", "--overwrite")
    assert r.exit_code == 2, r.output
    assert "m-s0" in error_line(r) and "kept" in error_line(r)
    assert fingerprint(user) == before


def test_overwrite_keeps_a_run_folder_a_user_added_a_file_to(flat_world_dir: Path, tmp_path: Path) -> None:
    m = mission(tmp_path, "m")
    runs = tmp_path / "runs"
    assert cli("run", "mission", m, "--world", flat_world_dir, "--out", runs).exit_code in (0, 1)
    (runs / "m-s0" / "analysis.ipynb").write_text("{}\n")
    before = fingerprint(runs / "m-s0")
    r = cli("run", "mission", m, "--world", flat_world_dir, "--out", runs, "--overwrite")
    assert r.exit_code == 2, r.output
    assert "analysis.ipynb" in error_line(r)
    assert fingerprint(runs / "m-s0") == before


def test_overwrite_replaces_vinecli_s_own_run_folder(flat_world_dir: Path, tmp_path: Path) -> None:
    """The guard does not stop the normal re-run: a folder vinecli made is replaced in one step."""
    m = mission(tmp_path, "m")
    runs = tmp_path / "runs"
    assert cli("run", "mission", m, "--world", flat_world_dir, "--out", runs).exit_code in (0, 1)
    first = (runs / "m-s0" / "summary.json").stat().st_mtime_ns
    r = cli("run", "mission", m, "--world", flat_world_dir, "--out", runs, "--overwrite")
    assert r.exit_code in (0, 1), r.output
    assert (runs / "m-s0" / "summary.json").stat().st_mtime_ns != first
    assert sorted(p.name for p in runs.iterdir() if p.name.startswith(".")) == [".vinecli"]  # no temp left
