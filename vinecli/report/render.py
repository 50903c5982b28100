"""Drawing what the report shows of each run: the figures that fit it (:mod:`~vinecli.report.figure_fit`) and its
field map (:mod:`~vinecli.report.fieldmap`), taken from the cache (:mod:`~vinecli.report.cache`) when they are
there, else drawn one item (a figure or a map) per task, the costly items first by a pool of worker processes
while this process draws the cheap ones, and cached.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any

from vinecli.report.cache import FigureCache, run_digest
from vinecli.report.loader import Run

__all__ = ["MAP", "RunDrawing", "draw_item", "draw_runs"]

log = logging.getLogger(__name__)
MAP = "map"
FIT_FILE = "fit.json"
#: the items that take longest, drawn first (the pool ends sooner)
COSTLY = (MAP, "fig16", "fig23", "fig20", "fig18")
#: fewer tasks than this are drawn in this process (starting workers would cost more)
POOL_MIN_TASKS = 4


@dataclass
class RunDrawing:
    """One run's figures (id -> {"png": bytes | None, "note", "caption"}, in figure order, the ones that do not
    fit with their reason) and map (its data, or None with ``map_note``)."""

    figures: dict[str, dict[str, Any]] = field(default_factory=dict)
    map: dict[str, Any] | None = None
    map_note: str = ""


_DATA: dict[str, Any] = {}  # a worker's plot data of the (two) runs it draws now


def draw_item(run_dir: str, item: str) -> tuple[str, str, bytes | None, str]:
    """(run_dir, item, bytes or None, note): a figure's PNG or a map's JSON; None with the note when the run has
    nothing to show or its data is too degenerate to draw. Top-level and picklable for the pool."""
    os.environ.setdefault("MPLBACKEND", "Agg")
    if item == MAP:
        from vinecli.report.fieldmap.build import run_map

        try:
            return run_dir, item, json.dumps(run_map(run_dir), allow_nan=False).encode(), ""
        except (ValueError, KeyError, IndexError, TypeError, OSError) as exc:
            log.warning("%s: map not drawn: %s", run_dir, exc)
            return run_dir, item, None, f"map not drawn: {type(exc).__name__}: {exc}"
    import matplotlib

    from vinecli.report.plots import FIGURES, NoData, load_plot_data

    # dense lines (10,000 samples of four rotors) simplified at half a pixel: 15 % faster, nothing visible lost
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


def _warm_worker() -> None:
    os.environ.setdefault("MPLBACKEND", "Agg")
    import vinecli.report.fieldmap.build  # noqa: F401 - imported once per worker, before the first task
    import vinecli.report.plots  # noqa: F401


def _fit(run: Run, key: str, cache: FigureCache) -> dict[str, str | None]:
    got = cache.get(key, FIT_FILE)
    if got is not None:
        return dict(json.loads(got))
    from vinecli.report.figure_fit import fitting_figures, run_profile

    fit = fitting_figures(run_profile(run.dir))  # type: ignore[arg-type]
    cache.put(key, FIT_FILE, json.dumps(fit).encode())
    return fit


def _item_file(item: str) -> str:
    return f"{item}.json" if item == MAP else f"{item}.png"


def draw_runs(runs: Sequence[Run], cache: FigureCache, workers: int = 1,
              progress: Callable[[int, int], None] | None = None, maps: bool = True) -> dict[str, RunDrawing]:
    """Figures (and maps) of ``runs`` by case; ``workers`` processes draw what the cache lacks."""
    from vinecli.report.fieldmap.context import find_world_dir
    from vinecli.report.plots import FIGURES

    out: dict[str, RunDrawing] = {}
    todo: list[tuple[str, str]] = []
    where: dict[str, tuple[str, str]] = {}  # run dir -> (case, key)
    for r in runs:
        if r.dir is None:
            continue
        key = run_digest(r.dir, find_world_dir(r.dir, r.summary))
        fit = _fit(r, key, cache)
        d = out[r.case] = RunDrawing()
        where[str(r.dir)] = (r.case, key)
        for fid, (caption, _fn) in FIGURES.items():
            note = fit.get(fid, "not drawn: unknown figure")
            d.figures[fid] = {"png": None, "note": note or "", "caption": caption}
            if note is None:
                todo.append((str(r.dir), fid))
        if maps:
            todo.append((str(r.dir), MAP))
    total, done = len(todo), 0
    pending = []
    for run_dir, item in todo:
        case, key = where[run_dir]
        got = cache.get(key, _item_file(item))
        if got is None:
            pending.append((run_dir, item))
            continue
        _store(out[case], item, got, "")
        done += 1
        if progress:
            progress(done, total)
    per_run = {d: sum(p[0] == d for p in pending) for d, _ in pending}  # busiest runs first, a run's items together
    pending.sort(key=lambda t: (-per_run[t[0]], t[0], COSTLY.index(t[1]) if t[1] in COSTLY else len(COSTLY)))
    for run_dir, item, data, note in _draw(pending, workers):
        case, key = where[run_dir]
        if data is not None:
            cache.put(key, _item_file(item), data)
        _store(out[case], item, data, note)
        done += 1
        if progress:
            progress(done, total)
    return out


def _store(d: RunDrawing, item: str, data: bytes | None, note: str) -> None:
    if item == MAP:
        d.map = json.loads(data) if data is not None else None
        d.map_note = note
    else:
        d.figures[item].update(png=data, note=note)


def _draw(pending: list[tuple[str, str]], workers: int) -> Any:
    """Draw ``pending`` (run dir, item); yields draw_item's results. With ``workers`` > 1, ``workers - 1`` spawned
    processes take the costly items from the front while this process draws from the back (no core idles while
    the workers start, and one process start fewer)."""
    from collections import deque
    from concurrent.futures import FIRST_COMPLETED, wait

    queue = deque(pending)
    if workers <= 1 or len(pending) < POOL_MIN_TASKS:
        while queue:
            yield draw_item(*queue.popleft())
        return
    import multiprocessing as mp

    with ProcessPoolExecutor(max_workers=workers - 1, mp_context=mp.get_context("spawn"),
                             initializer=_warm_worker) as ex:
        inflight: set[Any] = set()
        while queue or inflight:
            while queue and len(inflight) < 2 * (workers - 1):  # two queued per worker: none waits for work
                inflight.add(ex.submit(draw_item, *queue.popleft()))
            if queue:
                yield draw_item(*queue.pop())
            else:
                wait(inflight, return_when=FIRST_COMPLETED)
            for fut in [f for f in inflight if f.done()]:
                inflight.discard(fut)
                yield fut.result()
