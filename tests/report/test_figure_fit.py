"""Each run gets the figures that fit it (vinecli/report/figure_fit.py): no tank figures without a used tank, no
battery-and-sorties figure for one short sortie, no wind figure without wind, the spray figures only for a run that
sprayed; fig. 23 takes the field's shape."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from vinecli.report.figure_fit import RunProfile, fitting_figures, run_profile

from .synth_runs import MISSIONS

#: what the synthetic chapter-5 runs did, and so which figures they get
EXPECTED = {
    "takeoff": {"fig17", "fig18"},  # lift-off with a full tank: the tank force, the drag of the climb
    "overload": {"fig17", "fig20"},  # the tank force at rest and the rotors at their limit: it cannot take off
    # every lift-off with liquid aboard has its tank force, every flight through the air its drag
    "spray": {"fig16", "fig17", "fig18", "fig19", "fig20", "fig23", "fig24", "fig25"},  # the tank drains
    "gust": {"fig16", "fig17", "fig18", "fig20", "fig21"},  # the wind: drag, rotors and tilt follow it
}


@pytest.mark.parametrize("mission", MISSIONS)
def test_the_synthetic_runs_get_their_figures(ci_runs: Path, mission: str) -> None:
    fit = fitting_figures(run_profile(ci_runs / mission))
    drawn = {fid for fid, why in fit.items() if why is None}
    assert drawn - {"fig22"} == EXPECTED[mission]  # fig22 only when the battery was drawn down (no swaps here)
    assert all(why for fid, why in fit.items() if fid not in drawn)


BASE = RunProfile(has_position=True, airborne=True, tried_takeoff=False, extent_m=30.0, wind_mps=0.0,
                  airspeed_mps=3.0, tank_liquid=True, tank_used=True, mass_share=0.2, rotors=True, battery=True,
                  soc_drop=0.1, sorties=1, services=0, deposition=True, targeted_rows=True, budget=True)


def test_battery_and_sorties_need_sorties_swaps_or_a_drawn_battery() -> None:
    assert "one sortie" in fitting_figures(BASE)["fig22"]
    assert fitting_figures(replace(BASE, sorties=3))["fig22"] is None
    assert fitting_figures(replace(BASE, services=1))["fig22"] is None
    assert fitting_figures(replace(BASE, soc_drop=0.4))["fig22"] is None


def test_tank_wind_and_spray_figures_need_their_subject() -> None:
    dry = fitting_figures(replace(BASE, tank_liquid=False, tank_used=False, deposition=False, targeted_rows=False,
                                  budget=False, mass_share=0.0))
    assert all(dry[f] for f in ("fig17", "fig19", "fig20", "fig21", "fig23", "fig24", "fig25"))
    assert fitting_figures(replace(BASE, wind_mps=3.0, mass_share=0.0))["fig20"] is None  # rotors follow the wind
    assert fitting_figures(replace(BASE, wind_mps=3.0))["fig21"] is None
    ground = fitting_figures(replace(BASE, airborne=False, extent_m=0.0, airspeed_mps=0.0))
    assert ground["fig16"] and ground["fig18"] and ground["fig21"]
    # a lift-off with liquid aboard shows its tank force and a flight through still air its drag, checked or not
    # (a drone engineer reads the lift-off load and the drag at cruise speed off every such run)
    assert fitting_figures(BASE)["fig17"] is None and fitting_figures(BASE)["fig18"] is None
    assert fitting_figures(replace(BASE, airborne=False, tried_takeoff=True))["fig17"] is None
    assert "no lift-off" in fitting_figures(replace(BASE, airborne=False))["fig17"]
    assert "no liquid" in fitting_figures(replace(BASE, tank_liquid=False))["fig17"]
    assert "no drag" in fitting_figures(replace(BASE, airspeed_mps=0.2))["fig18"]


@pytest.mark.parametrize("aspect", [0.25, 0.6, 1.0, 3.4])
def test_fig23_takes_the_fields_shape(aspect: float) -> None:
    """The map's axes have the field's aspect; a tall field's figure is no wider than it needs, a wide field's map
    spans the figure."""
    from vinecli.report.deposition_plots import _fig23_layout

    fig, ax, _cax, _text, side = _fig23_layout(aspect)
    w_in, h_in = fig.get_size_inches()
    box = ax.get_position()
    assert box.height * h_in / (box.width * w_in) == pytest.approx(aspect, rel=0.02) or box.height * h_in == 2.0
    assert side == (aspect >= 0.8)
    if side:
        assert w_in <= max(8.0, box.width * w_in + 6.0)  # the map and its side panel (4.6 in), no more
    else:
        assert box.width > 0.8
