"""The dose as a grower judges it, over seeds: the spraying missions flown for seeds 0..N-1 with the
default dose checks on, and per mission the figures that say whether every vine got its dose:

* seeds passed (every check, the default dose checks included) and the statuses;
* the worst row: the largest |row mean rate / asked - 1| over the rows and the seeds (the check allows 0.15),
  the edge rows (first and last targeted row) against the inner ones;
* the hottest and the thinnest 1 m window along a planned row stretch (the checks allow 1.3x and 0.6x), and the
  same within 3 m of each sortie breakpoint (where a refill job resumed);
* dose faults and sprayer cut-outs located on the rows; ground services (s, landing bounces under 5 s left out),
  battery swaps with the state of charge they were made at, and the lowest state of charge at the end.

Missions (``--missions``): ``spray`` and ``job`` of ``pipelines/ci.yaml`` (sample vineyard, x500-sprayer) and
``block-job`` (vineyard block, ag-hexa-16). Each world is built once; each mission is one batch entry with
``seed: 0, seeds: N``. ``--runs DIR`` only summarises run directories already flown (e.g. by an earlier call with
``--keep``, or ``vinecli run batch``). A CPU-heavy sweep: ~1 min of CPU per block-job run.

    .venv/bin/python benchmarks/dose_seeds.py [--seeds 50] [--workers 2] [--missions spray job block-job]
                                              [--keep RUNS_DIR] [--runs RUNS_DIR ...] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
#: mission -> (mission file, world spec)
MISSIONS = {
    "spray": ("pipelines/missions/spray.yaml", "worlds/vineyard-sample.yaml"),
    "job": ("pipelines/missions/job.yaml", "worlds/vineyard-sample.yaml"),
    "block-job": ("pipelines/missions/block-job.yaml", "worlds/vineyard-block.yaml"),
}
_BOUNCE_S = 5.0  # a touchdown followed by a lift-off within this is a landing bounce, not a ground service
_NEAR_BP_M = 3.0  # windows this close to a breakpoint along its row are the resume's


def fly(missions: Sequence[str], n_seeds: int, workers: int, work: Path) -> Path:
    """Fly ``missions`` for seeds 0..n_seeds-1 under ``work``; the runs directory."""
    from vinecli.batch import run_batch
    from vinecli.batch.run import build_world_once

    entries = []
    for name in missions:
        mission, world = MISSIONS[name]
        built = build_world_once((REPO / world).resolve(), work / "_worlds")
        entries.append({"mission": str(REPO / mission), "world": str(built), "seed": 0, "seeds": n_seeds})
    pipe = work / "dose-seeds.yaml"
    pipe.write_text(json.dumps({"name": "dose-seeds", "seed": 0, "timeout_s": 3600, "missions": entries}))
    run_batch(pipe, work / "runs", workers=workers)
    return work / "runs"


def _row_at(rows: Sequence[dict[str, Any]], xy: Sequence[float]) -> tuple[dict[str, Any], float]:
    """The row of deposition.json nearest to ``xy`` (ENU m) and the metres along it."""
    p = np.asarray(xy[:2], float)
    best: tuple[float, dict[str, Any], float] | None = None
    for r in rows:
        line = np.asarray(r["polyline_enu"], float)
        s0 = 0.0
        for a, b in zip(line[:-1], line[1:], strict=True):
            d = b - a
            seg = float(np.hypot(*d))
            u = float(np.clip(np.dot(p - a, d) / max(seg * seg, 1e-12), 0.0, 1.0))
            dist = float(np.hypot(*(a + u * d - p)))
            if best is None or dist < best[0]:
                best = (dist, r, s0 + u * seg)
            s0 += seg
    assert best is not None
    return best[1], best[2]


def _windows(r: dict[str, Any], nominal: float, window_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(window centres along the row m, window mean / asked) over the row's planned stretch."""
    seg = float(r.get("segment_m", 0.5))
    rate = np.nan_to_num(np.asarray([np.nan if v is None else v for v in r["rate_lpha"]], float))
    s = (np.arange(rate.size) + 0.5) * seg
    p0, p1 = r["planned_m"]
    inside = (s >= p0 - 1e-9) & (s <= p1 + 1e-9)
    k = max(1, int(round(window_m / seg)))
    ri, si = rate[inside], s[inside]
    if ri.size < k:
        return si[:1], np.array([ri.mean() / nominal]) if ri.size else ri
    return si[: ri.size - k + 1] + 0.5 * (k - 1) * seg, np.convolve(ri, np.ones(k) / k, mode="valid") / nominal


def run_figures(run: Path) -> dict[str, Any]:
    """The dose figures of one run directory (module docstring)."""
    s = json.loads((run / "summary.json").read_text())
    events = [json.loads(x) for x in (run / "events.jsonl").read_text().splitlines() if x.strip()]
    out: dict[str, Any] = {"run": run.name, "mission": s["mission"], "seed": s.get("seed"), "status": s["status"],
                           "passed": bool(s["passed"]),
                           "failed": [c["name"] for c in s.get("checks", []) if not c.get("passed")]}
    lift = [e["t_s"] for e in events if e["kind"] == "liftoff"]
    down = [e["t_s"] for e in events if e["kind"] == "touchdown"]
    out["services_s"] = [round(nxt - td, 1) for td in down for nxt in [min((x for x in lift if x > td), default=None)]
                         if nxt is not None and nxt - td > _BOUNCE_S]
    out["swap_soc"] = [round(float(e["data"]["soc_before"]), 3) for e in events if e["kind"] == "battery_swap"]
    bps = [e["data"]["breakpoint_enu"] for e in events
           if e["kind"] == "sortie" and e["data"].get("event") == "end" and e["data"].get("breakpoint_enu")]
    dep_file = run / "deposition.json"
    if not dep_file.is_file():
        return out
    dep = json.loads(dep_file.read_text())
    nominal = float(dep["metrics"]["nominal_rate_lpha"])
    window_m = float((dep.get("dose_bands") or {}).get("window_m", 1.0))
    rows = [r for r in dep["rows"] if r.get("planned_m")]
    ratios = [float(r["mean_rate_lpha"]) / nominal for r in rows]
    wins = [_windows(r, nominal, window_m) for r in rows]
    out.update(row_ratios=[round(x, 4) for x in ratios], worst_row_error=max(abs(x - 1.0) for x in ratios),
               hottest=max(float(w.max()) for _s, w in wins if w.size), thinnest=min(float(w.min()) for _s, w in wins if w.size),
               faults=sum(len(r.get("faults") or []) for r in rows), cutouts=len(dep.get("sprayer_cutouts") or []))
    if len(rows) >= 3:
        out["edge_rows"] = [round(ratios[0], 4), round(ratios[-1], 4)]
        out["inner_rows_mean"] = round(float(np.mean(ratios[1:-1])), 4)
    near = []
    for bp in bps:
        r, along = _row_at(rows, bp)
        centres, w = wins[rows.index(r)]
        sel = np.abs(centres - along) <= _NEAR_BP_M
        if sel.any():
            near.append([round(float(w[sel].min()), 4), round(float(w[sel].max()), 4)])
    out["breakpoint_windows"] = near
    return out


def summarise(figures: Sequence[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per mission: seeds passed, worst row error, hottest / thinnest window, at the breakpoints, edge rows, services,
    swaps (module docstring)."""
    per: dict[str, list[dict[str, Any]]] = {}
    for f in figures:
        per.setdefault(f["mission"], []).append(f)
    out = {}
    for mission, fs in sorted(per.items()):
        dosed = [f for f in fs if "worst_row_error" in f]
        bp = [w for f in dosed for w in f["breakpoint_windows"]]
        edges = [x for f in dosed for x in f.get("edge_rows", [])]
        worst = max(dosed, key=lambda f: f["worst_row_error"]) if dosed else {}
        out[mission] = {
            "runs": len(fs), "passed": sum(f["passed"] for f in fs),
            "statuses": sorted({f["status"] for f in fs}),
            "failures": [{k: f[k] for k in ("run", "status", "failed")} for f in fs if not f["passed"]],
            "worst_row_error": worst.get("worst_row_error"), "worst_row_error_run": worst.get("run"),
            "median_worst_row_error": float(np.median([f["worst_row_error"] for f in dosed])) if dosed else None,
            "hottest": max((f["hottest"] for f in dosed), default=None),
            "thinnest": min((f["thinnest"] for f in dosed), default=None),
            "breakpoints": len(bp), "breakpoint_hottest": max((w[1] for w in bp), default=None),
            "breakpoint_thinnest": min((w[0] for w in bp), default=None),
            "edge_rows_min": min(edges, default=None), "edge_rows_max": max(edges, default=None),
            "inner_rows_mean": (float(np.mean([f["inner_rows_mean"] for f in dosed if "inner_rows_mean" in f]))
                                if any("inner_rows_mean" in f for f in dosed) else None),
            "faults": sum(f.get("faults", 0) for f in dosed), "cutouts": sum(f.get("cutouts", 0) for f in dosed),
            "services_s": [min((x for f in fs for x in f["services_s"]), default=None),
                           max((x for f in fs for x in f["services_s"]), default=None)],
            "swap_soc": sorted(x for f in fs for x in f["swap_soc"]),
        }
    return out


def _print(summary: dict[str, dict[str, Any]]) -> None:
    def g(v: Any, fmt: str = ".3f") -> str:
        return "-" if v is None else format(v, fmt)

    for mission, m in summary.items():
        print(f"{mission}: {m['passed']} of {m['runs']} seeds passed ({', '.join(m['statuses'])}); worst row error "
              f"{g(m['worst_row_error'])} ({m['worst_row_error_run']}, median {g(m['median_worst_row_error'])}); "
              f"hottest {g(m['hottest'])}x, thinnest {g(m['thinnest'])}x; at {m['breakpoints']} breakpoints "
              f"{g(m['breakpoint_thinnest'])}-{g(m['breakpoint_hottest'])}x; edge rows {g(m['edge_rows_min'])}-"
              f"{g(m['edge_rows_max'])} (inner {g(m['inner_rows_mean'])}); faults {m['faults']}, cut-outs "
              f"{m['cutouts']}; services {g(m['services_s'][0], '.0f')}-{g(m['services_s'][1], '.0f')} s; swaps at "
              f"{m['swap_soc'] or '-'}")
        for f in m["failures"]:
            print(f"    {f['run']}: {f['status']}; failed {', '.join(f['failed'])}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=50, help="seeds 0..N-1 per mission")
    ap.add_argument("--quick", action="store_true", help="smoke run: 2 seeds")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--missions", nargs="+", default=list(MISSIONS), choices=list(MISSIONS))
    ap.add_argument("--keep", type=Path, default=None, help="keep the run directories here (default: a temp dir)")
    ap.add_argument("--runs", type=Path, nargs="+", default=None, help="only summarise these runs directories")
    ap.add_argument("--json", type=Path, default=None, help="also write the figures as JSON")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="vinecli-dose-") as tmp_s:
        if args.runs:
            dirs = args.runs
        else:
            work = args.keep or Path(tmp_s)
            work.mkdir(parents=True, exist_ok=True)
            dirs = [fly(args.missions, 2 if args.quick else args.seeds, args.workers, work)]
        runs = [p.parent for d in dirs for p in sorted(Path(d).glob("*/summary.json"))]
        figures = [run_figures(r) for r in runs if json.loads((r / "summary.json").read_text())["status"] != "interrupted"]
    summary = summarise(figures)
    _print(summary)
    if args.json:
        args.json.write_text(json.dumps({"summary": summary, "runs": figures}, indent=1) + "\n")
    return 1 if any(m["passed"] < m["runs"] for m in summary.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
