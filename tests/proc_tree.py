"""Process trees from /proc, for tests that signal or kill a vinecli process and look for what is left
(``from proc_tree import descendants, alive``)."""

from __future__ import annotations

from pathlib import Path


def descendants(pid: int) -> set[int]:
    """Every live process below ``pid`` (from /proc/*/stat parent links)."""
    parents: dict[int, int] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            parents[int(d.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    out: set[int] = set()
    frontier = {pid}
    while frontier:
        frontier = {c for c, p in parents.items() if p in frontier} - out
        out |= frontier
    return out


def alive(pid: int) -> bool:
    """Is ``pid`` running (a zombie is not)?"""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def simulating(pid: int) -> bool:
    """The process has imported PyBullet (a batch worker past start-up, loading or running a case)."""
    try:
        return "pybullet" in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False
