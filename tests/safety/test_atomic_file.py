"""One temp-then-rename for single files (``outputs.atomic_file``): what the block wrote appears whole at the
path or not at all; a failing block, a symbolic link or a folder at the path leave everything as it was and no
temporary behind."""

from __future__ import annotations

from pathlib import Path

import pytest

from vinecli.errors import OutputError
from vinecli.outputs import atomic_file, write_bytes_atomic


def _siblings(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_the_block_s_file_replaces_the_path_whole(tmp_path: Path) -> None:
    out = tmp_path / "fields.gpkg"
    out.write_bytes(b"old")
    with atomic_file(out, ".gpkg") as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith(".fields.gpkg.tmp-") and tmp.suffix == ".gpkg"
        tmp.write_bytes(b"new")
        assert out.read_bytes() == b"old"  # nothing at the path until the block ends
    assert out.read_bytes() == b"new"
    assert _siblings(tmp_path) == ["fields.gpkg"]


def test_a_failing_block_leaves_the_path_as_it_was(tmp_path: Path) -> None:
    out = tmp_path / "plan.json"
    out.write_bytes(b"kept")
    with pytest.raises(ValueError), atomic_file(out) as tmp:
        tmp.write_bytes(b"half")
        raise ValueError("the writer failed")
    assert out.read_bytes() == b"kept"
    assert _siblings(tmp_path) == ["plan.json"]


def test_links_and_folders_at_the_path_are_refused_not_followed(tmp_path: Path) -> None:
    target = tmp_path / "elsewhere.txt"
    target.write_bytes(b"user's")
    (tmp_path / "link.txt").symlink_to(target)
    (tmp_path / "folder.txt").mkdir()
    for name in ("link.txt", "folder.txt"):
        with pytest.raises(OutputError, match="symbolic link or not a regular file"):
            write_bytes_atomic(tmp_path / name, b"x")
    assert target.read_bytes() == b"user's" and (tmp_path / "link.txt").is_symlink()
    assert _siblings(tmp_path) == ["elsewhere.txt", "folder.txt", "link.txt"]


def test_an_unwritable_folder_is_one_output_error(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="cannot write"):
        write_bytes_atomic(tmp_path / "missing" / "x.json", b"{}")
