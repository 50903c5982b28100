"""Drawing what the report shows of each run: the figures that fit it (:mod:`~vinecli.report.figure_fit`) and its
field map (:mod:`~vinecli.report.fieldmap`), taken from the cache (:mod:`~vinecli.report.cache`) when they are
there, else drawn one item (a figure or a map) per task and cached.

The time-series figures are chart JSON (:mod:`~vinecli.report.chart`, cheap): this process computes them. The PNG
figures and the maps go to a :class:`FigurePool`, started as soon as the runs are read and found not all cached:
on Linux this process imports the drawing code (:data:`PRELOAD`) and forks the workers, which start with it
imported and draw while it computes the charts; elsewhere a fork server preloads those modules once and forks the
workers from it (spawned processes where there is no fork server).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vinecli.report.cache import FigureCache, cache_root, run_digest
from vinecli.report.loader import Run

__all__ = ["MAP", "FigurePool", "RunDrawing", "all_cached", "draw_into_cache", "draw_item", "draw_runs"]

log = logging.getLogger(__name__)
MAP = "map"
FIT_FILE = "fit.json"
NOTE = ".note"  # an item that had nothing to show: its note, cached beside the drawn ones
#: the items that take longest, drawn first (the pool ends sooner)
COSTLY = (MAP, "fig16", "fig23", "fig25", "fig24")
#: fewer PNG items than this are drawn in this process (starting workers would cost more)
POOL_MIN_TASKS = 4
#: what the pool's processes import once, before they are forked (in this process or in a fork server). No warm-up
#: figure: drawing one cost 0.2 s before the fork and saved the workers 0.01 s (their first figures' fonts and
#: caches load as fast as it did)
PRELOAD = ["matplotlib.figure", "matplotlib.backends.backend_agg", "matplotlib.colors", "rasterio", "pyproj",
           "pyarrow.parquet", "pyarrow.dataset", "shapely.geometry", "vinecli.report.loader", "vinecli.report.plots",
           "vinecli.report.fieldmap.run_map"]


@dataclass
class RunDrawing:
    """One run's figures (id -> :func:`~vinecli.report.plots.figure_entry`, in figure order, the ones that do not
    fit with their reason) and map (its data, or None with ``map_note``)."""

    figures: dict[str, dict[str, Any]] = field(default_factory=dict)
    map: dict[str, Any] | None = None
    map_note: str = ""


_DATA: dict[str, Any] = {}  # a process's plot data of the (two) runs it draws now


def draw_item(run_dir: str, item: str) -> tuple[str, str, bytes | None, str]:
    """(run_dir, item, bytes or None, note): a figure's PNG or chart JSON, or a map's JSON; None with the note when
    the run has nothing to show or its data is too degenerate to draw. Top-level and picklable for the pool."""
    if item == MAP:
        from vinecli.report.fieldmap.run_map import run_map

        try:
            return run_dir, item, json.dumps(run_map(run_dir), allow_nan=False).encode(), ""
        except (ValueError, KeyError, IndexError, TypeError, OSError) as exc:
            log.warning("%s: map not drawn: %s", run_dir, exc)
            return run_dir, item, None, f"map not drawn: {type(exc).__name__}: {exc}"
    from vinecli.report.plots import CHARTS, FIGURES, NoData, load_plot_data

    if item not in CHARTS:
        import matplotlib

        # dense lines (10,000 samples of four rotors) simplified at half a pixel: nothing visible lost
        matplotlib.rcParams["path.simplify_threshold"] = 0.5
    if run_dir not in _DATA:
        if len(_DATA) >= 2:
            _DATA.pop(next(iter(_DATA)))
        _DATA[run_dir] = load_plot_data(run_dir)
    try:
        return run_dir, item, FIGURES[item][1](_DATA[run_dir]), ""
    except NoData as exc:
        return run_dir, item, None, str(exc)
    except (ValueError, IndexError, KeyError, FloatingPointError) as exc:  # data too degenerate to plot
        log.warning("%s: %s not drawn: %s", run_dir, item, exc)
        return run_dir, item, None, f"not drawn: {type(exc).__name__}: {exc}"


def _pool_context() -> tuple[Any, bool]:
    """(multiprocessing context, whether it forks this process). Fork on Linux when this process runs no other
    thread: this process imports :data:`PRELOAD` (0.4-0.6 s of CPU; what it has imported already, numpy, pyarrow, the run
    loader, a fork server would import again) and the workers forked from it start warm (each importing for
    itself costs 0.65 s of CPU a worker, in parallel: no sooner done on two cores, more CPU on a shared machine).
    Elsewhere a fork server that imports :data:`PRELOAD` once, or spawned processes. (Threads outside Python's
    count, pyarrow's jemalloc and thread pools, reinitialise themselves in a forked child.)"""
    import multiprocessing as mp
    import sys
    import threading

    if sys.platform == "linux" and threading.active_count() == 1 and "fork" in mp.get_all_start_methods():
        from importlib import import_module

        for name in PRELOAD:
            import_module(name)
        return mp.get_context("fork"), True
    if "forkserver" in mp.get_all_start_methods():
        ctx = mp.get_context("forkserver")
        ctx.set_forkserver_preload(PRELOAD)  # no effect when this process already runs a fork server
        return ctx, False
    return mp.get_context("spawn"), False


def _forked_worker_init(report_pid: int) -> None:
    """A forked worker dies with the report's process (``kill -9`` included: it holds the writing end of its own
    task queue, so no end of file would ever tell it) and leaves the stop signals to it (which ends the pool):
    SIGINT ignored, SIGTERM ends it, not the CLI's handler it inherited."""
    import signal

    from vinecli.lifeline import die_with_parent

    die_with_parent(report_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


class FigurePool:
    """``workers`` processes drawing PNG figures and maps. Forked ones start now (a few ms); a fork server or
    spawned ones are started by a thread of their own (the server answers once its imports are done) so the
    caller goes on at once. A context manager: leaving it ends the processes."""

    def __init__(self, workers: int) -> None:
        import threading

        self.workers = workers
        ctx, forks = _pool_context()
        import os

        self._ex = ProcessPoolExecutor(max_workers=workers, mp_context=ctx,
                                       initializer=_forked_worker_init if forks else None,
                                       initargs=(os.getpid(),) if forks else ())
        self._started: threading.Thread | None = None
        if forks:
            self._start()  # forks every worker now, from this thread (no other thread runs yet)
        else:
            self._started = threading.Thread(target=self._start, name="vinecli-figure-pool", daemon=True)
            self._started.start()

    def _start(self) -> None:
        for _ in range(self.workers):
            self._ex.submit(int)  # a task per worker: each process starts now

    def _wait_started(self) -> None:
        if self._started is not None:
            self._started.join()

    def submit(self, run_dir: str, item: str) -> Future[tuple[str, str, bytes | None, str]]:
        self._wait_started()
        return self._ex.submit(draw_item, run_dir, item)

    def close(self) -> None:
        self._wait_started()
        self._ex.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> FigurePool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _key(r: Run, keys: dict[str, str]) -> str:
    from vinecli.report.fieldmap.context import find_world_dir

    if r.case not in keys:
        keys[r.case] = run_digest(r.dir, find_world_dir(r.dir, r.summary))  # type: ignore[arg-type]
    return keys[r.case]


def _fit(run: Run, key: str, cache: FigureCache) -> dict[str, str | None]:
    got = cache.get(key, FIT_FILE)
    if got is not None:
        return dict(json.loads(got))
    from vinecli.report.figure_fit import fitting_figures, run_profile

    fit = fitting_figures(run_profile(run.dir))  # type: ignore[arg-type]
    cache.put(key, FIT_FILE, json.dumps(fit).encode())
    return fit


def _item_file(item: str) -> str:
    from vinecli.report.plots import CHARTS

    return f"{item}.json" if item == MAP or item in CHARTS else f"{item}.png"


def _items(fit: dict[str, str | None], maps: bool) -> list[str]:
    return [fid for fid, note in fit.items() if note is None] + ([MAP] if maps else [])


def all_cached(runs: Sequence[Run], cache: FigureCache, maps: bool = True, keys: dict[str, str] | None = None) -> bool:
    """Whether the cache holds every figure and map of ``runs`` (then no process needs starting)."""
    keys = {} if keys is None else keys
    for r in runs:
        if r.dir is None:
            continue
        key = _key(r, keys)
        got = cache.get(key, FIT_FILE)
        if got is None:
            return False
        if not all(cache.has(key, _item_file(i)) or cache.has(key, i + NOTE)
                   for i in _items(json.loads(got), maps)):
            return False
    return True


def draw_runs(runs: Sequence[Run], cache: FigureCache, workers: int = 1,
              progress: Callable[[int, int], None] | None = None, maps: bool = True,
              pool: FigurePool | None = None, keys: dict[str, str] | None = None) -> dict[str, RunDrawing]:
    """Figures (and maps) of ``runs`` by case: from the cache, else drawn (PNG figures and maps by ``pool``, or a
    pool of ``workers`` processes when there are enough of them, else by this process) and cached. ``keys``: the
    runs' cache keys by case, computed when missing."""
    from vinecli.report.plots import CHARTS, FIGURES, figure_entry

    keys = {} if keys is None else keys
    out: dict[str, RunDrawing] = {}
    where: dict[str, tuple[str, str]] = {}  # run dir -> (case, key)
    pending: list[tuple[str, str]] = []
    total = done = 0
    for r in runs:
        if r.dir is None:
            continue
        key = _key(r, keys)
        fit = _fit(r, key, cache)
        d = out[r.case] = RunDrawing()
        where[str(r.dir)] = (r.case, key)
        for fid, (caption, _fn) in FIGURES.items():
            d.figures[fid] = figure_entry(fid, None, fit.get(fid, "not drawn: unknown figure") or "", caption)
        for item in _items(fit, maps):
            total += 1
            got = cache.get(key, _item_file(item))
            note = cache.get(key, item + NOTE) if got is None else None
            if got is None and note is None:
                pending.append((str(r.dir), item))
                continue
            _store(d, item, got, note.decode() if note is not None else "")
            done += 1
    if progress and done:
        progress(done, total)
    for run_dir, item, data, note in _draw(pending, workers, pool, CHARTS):
        case, key = where[run_dir]
        if data is not None:
            cache.put(key, _item_file(item), data)
        else:
            cache.put(key, item + NOTE, note.encode())
        _store(out[case], item, data, note)
        done += 1
        if progress:
            progress(done, total)
    return out


def _store(d: RunDrawing, item: str, data: bytes | None, note: str) -> None:
    from vinecli.report.plots import figure_entry

    if item == MAP:
        d.map = json.loads(data) if data is not None else None
        d.map_note = note
    else:
        d.figures[item] = figure_entry(item, data, note, d.figures[item]["caption"])


def _draw(pending: list[tuple[str, str]], workers: int, pool: FigurePool | None,
          charts: frozenset[str]) -> Iterator[tuple[str, str, bytes | None, str]]:
    """Draw ``pending`` (run dir, item); yields draw_item's results. The PNG figures and maps go to ``pool`` (or a
    pool of ``workers`` started here when there are at least :data:`POOL_MIN_TASKS` of them), the costly ones first,
    while this process computes the charts; without a pool this process draws everything."""
    from concurrent.futures import as_completed

    heavy = sorted((p for p in pending if p[1] not in charts),
                   key=lambda p: (COSTLY.index(p[1]) if p[1] in COSTLY else len(COSTLY), p[0]))
    light = [p for p in pending if p[1] in charts]
    own = pool is None and workers > 1 and len(heavy) >= POOL_MIN_TASKS
    use = FigurePool(workers) if own else pool
    try:
        futures = [use.submit(*p) for p in heavy] if use is not None and heavy else []
        for p in light + ([] if futures else heavy):
            yield draw_item(*p)
        for fut in as_completed(futures):
            yield fut.result()
    finally:
        if own and use is not None:
            use.close()


def draw_into_cache(run_dir: str | Path, maps: bool = True) -> bool:
    """Draw the figures and the map of one finished run into the report's cache, in this process (a batch worker
    calls it when its run ends, so the first ``vinecli report`` over the batch finds them drawn). False when there
    was nothing to draw: the cache is off or holds them already."""
    root = cache_root()
    if root is None:
        return False
    from vinecli.report.loader import load_run

    cache, keys = FigureCache(root), {}
    run = [load_run(Path(run_dir))]
    if all_cached(run, cache, maps, keys):
        return False
    draw_runs(run, cache, workers=1, maps=maps, keys=keys)
    return True
