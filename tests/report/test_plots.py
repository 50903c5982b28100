"""Figures 16-25 from synthetic runs: every figure drawn (PNG size and content, or chart data that decodes to the
run's columns), graceful skips."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest

from vinecli.report.plots import (
    CHARTS,
    FIGURES,
    NoData,
    PlotData,
    check_spans,
    expected_size,
    fig17_tank_force,
    fig19_tank,
    fig20_rotors,
    load_plot_data,
    png_size,
    render_figures,
)

from .synth_runs import MISSIONS
from .test_chart import decode_chart

SPRAY_FIGURES = ("fig23", "fig24", "fig25")  # vinecli/report/deposition_plots.py, budget_plots.py
DOSE_FIGURES = ("fig26", "fig27")  # vinecli/report/dose_plots.py: runs with segment rates (tests/runs/test_dose_runs.py)


@pytest.fixture(scope="module")
def rendered(ci_runs: Path) -> dict[str, dict]:
    return {m: render_figures(str(ci_runs / m)) for m in MISSIONS}


def _pixels(png: bytes) -> np.ndarray:
    from matplotlib.image import imread

    return imread(io.BytesIO(png), format="png")


@pytest.mark.parametrize("mission", MISSIONS)
def test_every_figure_is_drawn_with_its_size(rendered: dict, mission: str) -> None:
    figs = rendered[mission]
    assert set(figs) == set(FIGURES)
    for fid, f in figs.items():
        if fid in SPRAY_FIGURES and mission != "spray":  # only a run that sprayed has a deposition
            assert f["png"] is None and "no deposition" in f["note"]
            continue
        if fid in CHARTS:  # drawn by the browser: chart data, no image
            assert f["png"] is None and f["chart"]["panels"], f"{mission} {fid}: {f['note']}"
            continue
        if fid in DOSE_FIGURES:  # none of the CI missions is dosed per segment
            assert f["png"] is None and "no segment rates" in f["note"]
            continue
        assert f["png"], f"{mission} {fid}: {f['note']}"
        assert len(f["png"]) > 10_000
        if fid not in ("fig16", "fig23"):  # fig. 16 and 23 take the shape of what they show
            assert png_size(f["png"]) == expected_size(fid)
        px = _pixels(f["png"])
        assert px.shape[:2] == png_size(f["png"])[::-1]
        assert float(px[..., :3].std()) > 0.05  # not a blank canvas


def test_chart_figures_carry_the_runs_columns(rendered: dict, ci_runs: Path) -> None:
    """Fig. 19's tank level is the run's column (within a 12-bit step); fig. 18's panels are x, y, z with the drag on
    the left axis and the wind and velocity on the right."""
    data = load_plot_data(ci_runs / "spray")
    t, panels = decode_chart(rendered["spray"]["fig19"]["chart"])
    level = panels[0][0]
    assert t.size == data.t.size and np.allclose(t, data.t, atol=6e-4)
    lvl = data.cols["tank_level_l"]
    assert np.nanmax(np.abs(level - lvl)) <= (np.nanmax(lvl) - np.nanmin(lvl)) / 4095 * 0.51 + 1e-12
    f18 = rendered["gust"]["fig18"]["chart"]
    assert [p["ylabel"] for p in f18["panels"]] == ["drag x, N (ENU)", "drag y, N (ENU)", "drag z, N (ENU)"]
    assert [[s["right"] for s in p["series"]] for p in f18["panels"]] == [[False, True, True]] * 3


def test_figures_differ_between_missions(rendered: dict) -> None:
    # the tank drains in spray but not in gust: figure 19's level must not be the same line
    spray = decode_chart(rendered["spray"]["fig19"]["chart"])[1][0][0]
    gust = decode_chart(rendered["gust"]["fig19"]["chart"])[1][0][0]
    assert np.ptp(spray) > 0.1 and np.ptp(gust) < 1e-6


def test_no_tank_skips_tank_figures_with_a_note(ci_runs: Path) -> None:
    data = load_plot_data(ci_runs / "gust")
    cols = {k: v for k, v in data.cols.items() if not k.startswith("tank_")}
    dry = PlotData(cols=cols, events=data.events, summary=data.summary, preview=data.preview)
    with pytest.raises(NoData, match="tank"):
        fig17_tank_force(dry)
    with pytest.raises(NoData, match="tank"):
        fig19_tank(dry)
    assert json.loads(fig20_rotors(dry))["panels"][0]["ylabel"] == "rotor speed, rad/s"  # rotors still drawn


def test_empty_tank_has_no_tank_force_figure(ci_runs: Path) -> None:
    data = load_plot_data(ci_runs / "takeoff")
    data.cols["tank_mass_kg"] = np.zeros_like(data.cols["tank_mass_kg"])
    with pytest.raises(NoData, match="tank"):
        fig17_tank_force(data)


def test_render_figures_reports_the_skip_note(tmp_path: Path, ci_runs: Path) -> None:
    import shutil

    import pyarrow.parquet as pq

    d = tmp_path / "run"
    shutil.copytree(ci_runs / "gust", d)
    t = pq.read_table(d / "timeseries.parquet")
    pq.write_table(t.drop_columns([n for n in t.column_names if n.startswith("tank_")]), d / "timeseries.parquet")
    figs = render_figures(str(d), only=["fig17", "fig21"])
    assert figs["fig17"]["png"] is None and "no tank" in figs["fig17"]["note"]
    assert figs["fig21"]["chart"]["title"].startswith("Fig. 21")


def test_main_liftoff_ignores_a_spawn_bounce() -> None:
    t = np.arange(0.0, 10.0, 0.01)
    og = np.ones_like(t)
    og[(t > 0.0) & (t < 0.05)] = 0.0  # bounce when the vehicle is dropped on the terrain
    og[t >= 3.0] = 0.0  # the real lift-off
    data = PlotData(cols={"t_s": t, "on_ground": og}, events=[{"t_s": 0.01, "kind": "liftoff"}])
    assert data.liftoff() == pytest.approx(3.0)


def test_check_windows_go_to_the_figures_of_their_quantities() -> None:
    checks = [
        {"name": "holds_position", "quantity": "metric:hpos_error_max_m", "window": [13.0, 45.0], "passed": True},
        {"name": "drain", "quantity": "metric:drain_time_ratio", "window": [5.0, 25.0], "passed": False},
        {"name": "rotor", "quantity": "metric:rotor_mass_correlation", "window": [5.0, 25.0], "passed": True},
        {"name": "nowin", "quantity": "metric:tilt_into_wind_ratio", "window": None, "passed": True},
    ]
    assert [c["name"] for c in check_spans("fig21", checks)] == ["holds_position"]
    assert [c["name"] for c in check_spans("fig19", checks)] == ["drain"]
    assert [c["name"] for c in check_spans("fig20", checks)] == ["rotor"]


def test_png_size_rejects_non_png() -> None:
    with pytest.raises(ValueError):
        png_size(b"GIF89a" + b"\0" * 30)


def test_a_run_without_samples_gets_notes_not_figures(tmp_path: Path, ci_runs: Path) -> None:
    import shutil

    import pyarrow.parquet as pq

    d = tmp_path / "run"
    shutil.copytree(ci_runs / "takeoff", d)
    pq.write_table(pq.read_table(d / "timeseries.parquet").slice(0, 0), d / "timeseries.parquet")
    figs = render_figures(str(d))
    assert all(f["png"] is None and f["chart"] is None and f["note"].startswith("no ") for f in figs.values())


def test_the_dose_colour_scale_is_fixed_on_the_asked_rate() -> None:
    from vinecli.report.deposition_plots import dose_scale

    rates = np.array([0.0, 20.0, 24.0, 26.0, 29.0, np.nan])
    _cmap, norm = dose_scale(25.0, rates)  # the same colour is the same share of the asked rate in every run
    assert (norm.vmin, norm.vcenter, norm.vmax) == (0.0, 25.0, 50.0) and float(norm(25.0)) == pytest.approx(0.5)
    _cmap, over = dose_scale(25.0, np.full(100, 80.0))  # an overdosed field keeps its pattern
    assert over.vmax == pytest.approx(80.0)
    _cmap, free = dose_scale(float("nan"), rates)  # no asked rate: 0 to the highest
    assert free.vmax == pytest.approx(29.0)


def test_a_colour_scale_keeps_its_steps(rendered: dict) -> None:
    """Fig. 23's dose scale keeps its colours (a 256-colour palette shared with the hillshade's greys turned it
    into bands): the column richest in coloured steps (through the colour bar or the map; the hillshade's greys
    not counted) holds well over the ~50 steps a shared palette left."""
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(rendered["spray"]["fig23"]["png"])).convert("RGB")).astype(int)
    coloured = img.max(axis=2) - img.min(axis=2) > 60
    steps = max(len({tuple(p) for p in img[coloured[:, c], c]}) for c in range(img.shape[1]))
    assert steps > 150  # 56 with a shared palette, 246 as RGB (the colour bar alone: 259-268)


def test_the_drift_curve_reads_on_log_axes_and_keeps_its_zeros() -> None:
    """Fig. 25's drift: both axes logarithmic (a 68 % point at 1 m flattened 3-50 m into one line at 0 on a linear
    axis), and the distances with no drift on the ground stay on the plot, at the axis' floor, marked 0."""
    from matplotlib.figure import Figure

    from vinecli.report.budget_plots import DRIFT_FLOOR_PCT, _drift

    ax = Figure().subplots()
    curve = [{"distance_m": d, "percent_of_applied": v} for d, v in ((1, 68.0), (3, 0.4), (5, 0.02), (10, 0.0))]
    _drift(ax, {"drift_curve": curve, "drift": {"calm": True}})
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert ax.get_ylim()[0] == pytest.approx(DRIFT_FLOOR_PCT) and ax.get_ylim()[1] > 68.0
    run, zero = ax.lines[0], ax.lines[1]
    assert list(run.get_xdata()) == [1, 3, 5] and list(run.get_ydata()) == [68.0, 0.4, 0.02]
    assert list(zero.get_xdata()) == [10] and list(zero.get_ydata()) == [DRIFT_FLOOR_PCT]
    assert [t.get_text() for t in ax.texts] == ["68", "0.4", "0.02", "0"]
