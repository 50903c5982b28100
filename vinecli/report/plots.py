"""The figures of one run, as PNG bytes: the thesis §5 figures (16-21), the battery / sorties figure (22) and
the deposition figures (23, 24), registered in :data:`FIGURES` (id -> caption, function).

matplotlib object API only (:class:`matplotlib.figure.Figure` + ``FigureCanvasAgg``, no pyplot
state). Each ``figNN_*`` function takes a :class:`PlotData` and returns PNG bytes, or raises
:class:`NoData` with a note when the run has nothing to show (e.g. no tank). World frame ENU
(x east, y north, z up), body FLU, SI units; check windows are shaded (green passed, red failed)
on the figures whose quantities they test (:mod:`~vinecli.report.figure_marks`). The figures by family:
:mod:`~vinecli.report.path_plots` (16), :mod:`~vinecli.report.tank_plots` (17-19),
:mod:`~vinecli.report.flight_plots` (20-22), :mod:`~vinecli.report.deposition_plots` (23, 24).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from vinecli.report.budget_plots import fig25_budget
from vinecli.report.deposition_plots import fig23_deposition, fig24_row_coverage
from vinecli.report.dose_plots import fig26_dose_maps, fig27_dose_quality
from vinecli.report.figure_base import DPI, SIZES, NoData, PlotData, columns_needed
from vinecli.report.figure_marks import check_spans
from vinecli.report.flight_plots import fig20_rotors, fig21_attitude, fig22_battery
from vinecli.report.path_plots import fig16_path
from vinecli.report.tank_plots import fig17_tank_force, fig18_drag, fig19_tank

log = logging.getLogger(__name__)


#: figure id -> (caption, function)
FIGURES: dict[str, tuple[str, Callable[[PlotData], bytes]]] = {
    "fig16": ("Flown path over the terrain with vine rows, wind arrows and geofence", fig16_path),
    "fig17": ("Tank force along z: gravitational and inertial parts around lift-off", fig17_tank_force),
    "fig18": ("Drag force components x, y, z with the wind and the drone velocity", fig18_drag),
    "fig19": ("Tank level and liquid mass vs time with the flow command", fig19_tank),
    "fig20": ("Rotor speeds against the factors that drive them (mass, wind)", fig20_rotors),
    "fig21": ("Roll, pitch, yaw vs wind: the tilt into the gust", fig21_attitude),
    "fig22": ("Battery voltage, state of charge and power; sorties and battery swaps of a refill job", fig22_battery),
}


FIGURES["fig23"] = ("Spray deposition (L/ha) over the terrain with the rows, the flown path and the fence",
                    fig23_deposition)
FIGURES["fig24"] = ("Coverage along the targeted rows: rate along each row and the share covered", fig24_row_coverage)
FIGURES["fig25"] = ("Where the spray went: canopy, ground in and off the field, airborne, evaporated (per row) "
                    "and the drift curve downwind", fig25_budget)
FIGURES["fig26"] = ("Segment rates: the prescription, the rate the pump applied and the error, side by side",
                    fig26_dose_maps)
FIGURES["fig27"] = ("As applied: error histogram, transition distances against the pump-lag bound, product saved "
                    "against a uniform rate", fig27_dose_quality)


def load_plot_data(run_dir: str | Path, columns: Sequence[str] | None = None) -> PlotData:
    """Read what the figures need from a (validated) run directory."""
    from vinecli.constants import STANDARD_GRAVITY
    from vinecli.report.loader import load_run
    from vinecli.runs.rundir import world_gravity

    run = load_run(Path(run_dir))
    g = world_gravity(run.summary)
    return PlotData(cols=run.read_columns(columns or columns_needed()), events=run.events(), summary=run.summary,
                    preview=run.preview(), run_dir=Path(run_dir), gravity=STANDARD_GRAVITY if g is None else g)


def render_figures(run_dir: str, only: Sequence[str] | None = None) -> dict[str, dict[str, Any]]:
    """All figures of one run: ``{fig id: {"png": bytes | None, "note": str, "caption": str}}``.

    Top-level and picklable: the report maps it over a process pool.
    """
    data = load_plot_data(run_dir)
    out: dict[str, dict[str, Any]] = {}
    for fid, (caption, fn) in FIGURES.items():
        if only is not None and fid not in only:
            continue
        try:
            out[fid] = {"png": fn(data), "note": "", "caption": caption}
        except NoData as exc:
            out[fid] = {"png": None, "note": str(exc), "caption": caption}
        except (ValueError, IndexError, KeyError, FloatingPointError) as exc:  # data too degenerate to plot
            log.warning("%s: %s not drawn: %s", run_dir, fid, exc)
            out[fid] = {"png": None, "note": f"not drawn: {type(exc).__name__}: {exc}", "caption": caption}
    return out


def png_size(png: bytes) -> tuple[int, int]:
    """(width, height) in pixels from a PNG's IHDR chunk."""
    if png[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    return int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")


def expected_size(fid: str) -> tuple[int, int]:
    w, h = SIZES[fid]
    return int(round(w * DPI)), int(round(h * DPI))


__all__ = ["FIGURES", "NoData", "PlotData", "check_spans", "expected_size", "load_plot_data", "png_size",
           "render_figures"]
