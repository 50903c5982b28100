"""The report's cache (vinecli/report/cache.py): a second report over the same runs draws nothing and is the same
page; a changed run is drawn again, the others are not; the key follows every file of the run and its world;
``VINECLI_CACHE_DIR=off`` keeps nothing."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

import vinecli.report.render as render
from vinecli.report import build_report
from vinecli.report.cache import FigureCache, run_digest


def _body(html: Path) -> str:
    return re.sub(r"generated [0-9T:+-]+", "", html.read_text(encoding="utf-8"))


@pytest.fixture()
def drawn(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, str]]:
    """Every (run dir, item) drawn (not taken from the cache)."""
    calls: list[tuple[str, str]] = []
    real = render.draw_item

    def spy(run_dir: str, item: str):  # noqa: ANN202
        calls.append((Path(run_dir).name, item))
        return real(run_dir, item)

    monkeypatch.setattr(render, "draw_item", spy)
    return calls


def test_a_second_report_draws_nothing(ci_runs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                       drawn: list[tuple[str, str]]) -> None:
    runs = tmp_path / "runs"
    shutil.copytree(ci_runs, runs)
    monkeypatch.setenv("VINECLI_CACHE_DIR", str(tmp_path / "cache"))
    first = build_report(runs, tmp_path / "a", workers=1)
    n = len(drawn)
    assert n > 4 and {d for d, _ in drawn} == {"takeoff", "overload", "spray", "gust"}
    second = build_report(runs, tmp_path / "b", workers=1)
    assert len(drawn) == n  # all from the cache
    assert _body(second.html) == _body(first.html)
    # one run changes (its events): only it is drawn again
    ev = runs / "gust" / "events.jsonl"
    ev.write_text(ev.read_text() + '{"t_s": 1.0, "kind": "note", "message": "x"}\n')
    build_report(runs, tmp_path / "c", workers=1)
    assert {d for d, _ in drawn[n:]} == {"gust"}


def test_the_key_follows_the_runs_files_and_its_world(ci_runs: Path, tmp_path: Path) -> None:
    run = tmp_path / "spray"
    shutil.copytree(ci_runs / "spray", run)
    world = tmp_path / "world"
    world.mkdir()
    (world / "world.json").write_text('{"name": "w"}')
    k0 = run_digest(run, world)
    assert run_digest(run, world) == k0 and run_digest(run, None) != k0
    (world / "world.json").write_text('{"name": "w2"}')
    k1 = run_digest(run, world)
    assert k1 != k0
    with open(run / "deposition.tif", "r+b") as f:  # one byte of the deposition
        f.seek(-1, 2)
        last = f.read(1)
        f.seek(-1, 2)
        f.write(bytes([last[0] ^ 1]))
    assert run_digest(run, world) != k1


def test_off_keeps_nothing(ci_runs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from vinecli.report.cache import cache_root

    monkeypatch.setenv("VINECLI_CACHE_DIR", "off")
    assert cache_root() is None
    c = FigureCache(cache_root())
    c.put("ab" * 20, "x.png", b"x")
    assert c.get("ab" * 20, "x.png") is None
    monkeypatch.delenv("VINECLI_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache_root() == tmp_path / "vinecli" / "report"


def test_prune_keeps_the_cache_under_its_size(tmp_path: Path) -> None:
    import os

    c = FigureCache(tmp_path)
    for k in range(5):
        key = f"{k:02d}" * 20
        c.put(key, "a.png", b"x" * 1000)
        old = 1_000_000 + k
        os.utime(tmp_path / key[:2] / key, (old, old))
    c.prune(max_bytes=2500)
    left = sorted(p.name[:2] for p in tmp_path.glob("*/*"))
    assert left == ["03", "04"]  # the most recently used


def test_a_batch_worker_draws_its_run_for_the_first_report(ci_runs: Path, tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch,
                                                           drawn: list[tuple[str, str]]) -> None:
    """What a batch worker does when its run ends (batch/case.py): the run's figures and map go into the cache, so
    the first report over the batch draws nothing; with the cache off it draws nothing at the run's end either."""
    from vinecli.batch.case import _draw_for_report
    from vinecli.report.render import draw_into_cache
    from vinecli.runs.request import RunRequest

    runs = tmp_path / "runs"
    shutil.copytree(ci_runs, runs)
    monkeypatch.setenv("VINECLI_CACHE_DIR", "off")
    assert draw_into_cache(runs / "spray") is False and drawn == []
    monkeypatch.setenv("VINECLI_CACHE_DIR", str(tmp_path / "cache"))
    for case in ("takeoff", "overload", "spray", "gust"):  # as each worker's run ends
        _draw_for_report(RunRequest(mission="m.yaml", world_dir=tmp_path, runs_dir=runs, run_id=case, case=case))
    n = len(drawn)
    assert {d for d, _ in drawn} == {"takeoff", "overload", "spray", "gust"} and ("spray", "map") in drawn
    cached = sorted(p.relative_to(tmp_path) for p in (tmp_path / "cache").rglob("*") if p.is_file())
    build_report(runs, tmp_path / "report", workers=2)
    # the first report: everything from the cache (nothing drawn here, nothing new cached from a worker)
    assert len(drawn) == n and sorted(p.relative_to(tmp_path) for p in (tmp_path / "cache").rglob("*")
                                      if p.is_file()) == cached
    assert draw_into_cache(runs / "spray") is False  # and drawn once
    _draw_for_report(RunRequest(mission="m.yaml", world_dir=tmp_path, runs_dir=runs, run_id="gone", case="gone"))
