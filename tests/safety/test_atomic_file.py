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
    (tmp_path / "a-file").write_bytes(b"mine")
    with pytest.raises(OutputError, match="cannot create"):
        write_bytes_atomic(tmp_path / "a-file" / "x.json", b"{}")
    assert _siblings(tmp_path) == ["a-file"]


def test_missing_folders_are_made_and_removed_again_when_the_write_fails(tmp_path: Path) -> None:
    """A failed write leaves no folder it made."""
    with pytest.raises(ValueError), atomic_file(tmp_path / "new" / "a" / "x.gpkg") as tmp:
        assert tmp.parent.is_dir()
        raise ValueError("the writer failed")
    assert _siblings(tmp_path) == []
    write_bytes_atomic(tmp_path / "new" / "a" / "x.json", b"{}")
    assert (tmp_path / "new" / "a" / "x.json").read_bytes() == b"{}"


def test_a_file_that_appears_meanwhile_is_kept_without_overwrite(tmp_path: Path) -> None:
    """One writer per output path. Another writer's file that appears while this one writes is
    never replaced without ``overwrite``; this one fails with one OutputError and leaves no temporary."""
    out = tmp_path / "field.gpkg"
    with pytest.raises(OutputError, match="another process"), atomic_file(out, ".gpkg", overwrite=False) as tmp:
        tmp.write_bytes(b"mine")
        out.write_bytes(b"the other writer's")
    assert out.read_bytes() == b"the other writer's"
    assert _siblings(tmp_path) == ["field.gpkg"]


def test_a_second_writer_of_the_same_path_is_refused_while_the_first_writes(tmp_path: Path) -> None:
    """Class 6: the path's lock is held for the whole block; a writer in another process gets ``in use by pid N``."""
    import subprocess
    import sys

    out = tmp_path / "rows.geojson"
    with atomic_file(out, overwrite=False) as tmp:
        tmp.write_bytes(b"first")
        code = ("import sys; from vinecli.outputs import write_bytes_atomic; from vinecli.errors import OutputError\n"
                "try:\n    write_bytes_atomic(sys.argv[1], b'second', overwrite=False)\n"
                "except OutputError as e:\n    print(e); sys.exit(2)\n")
        r = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True, timeout=60)
        assert r.returncode == 2 and "in use by pid" in r.stdout, r
    assert out.read_bytes() == b"first"
    assert _siblings(tmp_path) == ["rows.geojson"]
