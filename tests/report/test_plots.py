"""Figures 16-21 from synthetic runs: every figure drawn, PNG size, content, graceful skips."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from vinecli.report.plots import (
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
        if fid in DOSE_FIGURES:  # none of the CI missions is dosed per segment
            assert f["png"] is None and "no segment rates" in f["note"]
            continue
        assert f["png"], f"{mission} {fid}: {f['note']}"
        assert len(f["png"]) > 10_000
        assert png_size(f["png"]) == expected_size(fid)
        px = _pixels(f["png"])
        assert px.shape[:2] == expected_size(fid)[::-1]
        assert float(px[..., :3].std()) > 0.05  # not a blank canvas


def test_figures_differ_between_missions(rendered: dict) -> None:
    # the tank drains in spray but not in gust: figure 19 must not be the same picture
    a, b = _pixels(rendered["spray"]["fig19"]["png"]), _pixels(rendered["gust"]["fig19"]["png"])
    assert np.abs(a - b).mean() > 0.01


def test_no_tank_skips_tank_figures_with_a_note(ci_runs: Path) -> None:
    data = load_plot_data(ci_runs / "gust")
    cols = {k: v for k, v in data.cols.items() if not k.startswith("tank_")}
    dry = PlotData(cols=cols, events=data.events, summary=data.summary, preview=data.preview)
    with pytest.raises(NoData, match="tank"):
        fig17_tank_force(dry)
    with pytest.raises(NoData, match="tank"):
        fig19_tank(dry)
    assert png_size(fig20_rotors(dry)) == expected_size("fig20")  # rotors still drawn


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
    assert png_size(figs["fig21"]["png"]) == expected_size("fig21")


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
    assert all(f["png"] is None and f["note"].startswith("no ") for f in figs.values())


def test_the_dose_colour_scale_is_fixed_on_the_asked_rate() -> None:
    from vinecli.report.deposition_plots import dose_scale

    rates = np.array([0.0, 20.0, 24.0, 26.0, 29.0, np.nan])
    _cmap, norm = dose_scale(25.0, rates)  # the same colour is the same share of the asked rate in every run
    assert (norm.vmin, norm.vcenter, norm.vmax) == (0.0, 25.0, 50.0) and float(norm(25.0)) == pytest.approx(0.5)
    _cmap, over = dose_scale(25.0, np.full(100, 80.0))  # an overdosed field keeps its pattern
    assert over.vmax == pytest.approx(80.0)
    _cmap, free = dose_scale(float("nan"), rates)  # no asked rate: 0 to the highest
    assert free.vmax == pytest.approx(29.0)
