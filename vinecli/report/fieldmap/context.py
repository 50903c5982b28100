"""What the map's layers read of one run: the run directory's files, its world and the world's georeference.

The georeference is the world's (:func:`vinecli.gis.georef.world_dir_georef`: through the DSM's CRS for a world
built on one), found at the path the run recorded, else beside the runs (``RUNS/_worlds/<name>``, a batch's runs
moved or downloaded as one folder). Without the world folder the map falls back to the topocentric frame of the
world's recorded origin and says so (a world laid on a CRS grid is then off by the grid's convergence).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from vinecli.gis.georef import Georef

__all__ = ["MapContext", "find_world_dir", "load_context"]

#: time-series columns the map reads
COLUMNS = ("t_s", "pos_enu_x_m", "pos_enu_y_m", "height_agl_m", "phase_index", "tank_flow_lps", "on_ground")


@dataclass
class MapContext:
    """One run for the map: ``summary`` (summary.json), ``world`` (world.json, {} when gone), ``georef``,
    ``georef_note`` (why the positions are approximate, "" when exact), ``cols`` (time series, SI, world ENU),
    ``events`` (events.jsonl), ``preview`` (the terrain preview: x, y 1-D, z[y, x]), ``run_dir``."""

    run_dir: Path
    summary: dict[str, Any]
    world: dict[str, Any]
    world_dir: Path | None
    georef: Georef
    georef_note: str = ""
    cols: dict[str, np.ndarray] = field(default_factory=dict)
    events: list[dict[str, Any]] = field(default_factory=list)
    preview: dict[str, np.ndarray] | None = None

    def json(self, name: str) -> dict[str, Any] | None:
        """A JSON file of the run directory (deposition.json, budget.json), None when absent."""
        p = self.run_dir / name
        return json.loads(p.read_text(encoding="utf-8")) if p.is_file() else None

    @cached_property
    def deposition(self) -> dict[str, Any] | None:
        return self.json("deposition.json")

    @cached_property
    def budget(self) -> dict[str, Any] | None:
        return self.json("budget.json")

    @cached_property
    def as_applied(self) -> dict[str, Any] | None:
        """as_applied.json of a run that flew segment rates (a canopy dose or a prescription map)."""
        return self.json("as_applied.json")

    @staticmethod
    def row_name(row: dict[str, Any]) -> Any:
        """A deposition row's name: the world's row number when the mission named world rows, else its index."""
        return row["row"] if row.get("world_row") is None else row["world_row"]

    @property
    def rows(self) -> list[list[tuple[float, float]]]:
        """The world's vine rows (ENU m polylines)."""
        return [[(float(p[0]), float(p[1])) for p in r] for r in (self.summary.get("world") or {}).get("rows_enu") or []
                if len(r) >= 2]

    @property
    def fence(self) -> list[tuple[float, float]]:
        g = (self.summary.get("world") or {}).get("geofence") or self.world.get("geofence") or {}
        return [(float(p[0]), float(p[1])) for p in g.get("polygon_enu") or []]

    def position_at(self, t: float) -> tuple[float, float] | None:
        """The vehicle's (x, y) at the last sample at or before ``t`` s."""
        ts = self.cols.get("t_s")
        if ts is None or not ts.size or "pos_enu_x_m" not in self.cols:
            return None
        i = max(int(np.searchsorted(ts, t, side="right")) - 1, 0)
        return float(self.cols["pos_enu_x_m"][i]), float(self.cols["pos_enu_y_m"][i])


def find_world_dir(run_dir: Path, summary: dict[str, Any]) -> Path | None:
    """The run's world folder: the recorded path, else ``<runs>/_worlds/<name>`` beside the run; None when gone."""
    w = summary.get("world") or {}
    cands = [Path(str(w["dir"]))] if isinstance(w, dict) and w.get("dir") else []
    if isinstance(w, dict) and w.get("name"):
        cands.append(run_dir.parent / "_worlds" / str(w["name"]))
    return next((c for c in cands if (c / "world.json").is_file()), None)


def load_context(run_dir: Path | str) -> MapContext:
    """Read one run directory for the map (module docstring for the georeference)."""
    from vinecli.geo import GeoOrigin
    from vinecli.gis.georef import world_dir_georef
    from vinecli.report.loader import load_run

    run = load_run(Path(run_dir))
    summary = run.summary
    wdir = find_world_dir(run.dir or Path(run_dir), summary)
    world: dict[str, Any] = {}
    note = ""
    if wdir is not None:
        world = json.loads((wdir / "world.json").read_text(encoding="utf-8"))
        georef = world_dir_georef(wdir)
    else:
        origin = (summary.get("world") or {}).get("origin") or {"lat": 0.0, "lon": 0.0, "alt": 0.0}
        georef = Georef(None, GeoOrigin.from_dict(origin))
        note = ("the run's world folder is gone: positions use the tangent plane at the world's origin "
                "(a world built on a DSM's CRS may be off by a few metres)")
    return MapContext(run_dir=Path(run_dir), summary=summary, world=world, world_dir=wdir, georef=georef,
                      georef_note=note, cols=run.read_columns(COLUMNS), events=run.events(),
                      preview=run.preview())
