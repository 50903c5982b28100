"""The spray budget's models against their formulas: canopy, interception, evaporation, drift (docs/budget.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vinecli.spray.canopy import BBCH_DEFAULTS, Canopy, Hedge, bbch_dims, measure_row_heights, row_spacing
from vinecli.spray.drift import drift_curve, drift_frames, field_polygon, field_split
from vinecli.spray.evaporation import (
    evaporation_constant,
    remaining_fraction,
    saturation_vapour_pressure_pa,
    wet_bulb_c,
)
from vinecli.spray.interception import (
    capture_fraction,
    impaction_efficiency,
    leaf_area_on_path,
    semicircle_cdf,
    stokes_number,
)


# ---------------------------------------------------------------- canopy
def test_bbch_table_grows_and_full_canopy_matches_biglia():
    stages = sorted(BBCH_DEFAULTS)
    lai = [BBCH_DEFAULTS[s].lad_m2m3 * BBCH_DEFAULTS[s].width_m * (BBCH_DEFAULTS[s].top_m - BBCH_DEFAULTS[s].base_m)
           for s in stages]
    assert lai[0] == 0.0 and all(b > a for a, b in zip(lai, lai[1:], strict=False))
    full = bbch_dims(89)
    # Biglia et al. 2022 §2.4: LAI 1.5-1.9 at 2.5 m row spacing
    assert 1.5 <= full.lad_m2m3 * full.width_m * (full.top_m - full.base_m) / 2.5 <= 1.9
    assert 3.0 <= full.lad_m2m3 <= 7.0  # Kliewer & Dokoozlian 2005 range
    assert bbch_dims(64) == BBCH_DEFAULTS[61]
    with pytest.raises(ValueError):
        bbch_dims(100)


def test_canopy_leaf_area_and_lai():
    rows = [[(0.0, 0.0), (0.0, 10.0)], [(2.5, 0.0), (2.5, 10.0)]]
    c = Canopy(rows=tuple(tuple(r) for r in rows), hedges=(Hedge(0, 0.5, 2.0, 0.5, 4.0), Hedge(1, 0.5, 2.0, 0.5, 4.0)),
               profile=(1.0, 3.0), spacing_m=row_spacing(rows))
    assert c.profile == (0.5, 1.5)  # normalised to mean 1
    assert c.leaf_area_m2(0) == pytest.approx(4.0 * 0.5 * 1.5 * 10.0)
    assert c.lai() == pytest.approx(4.0 * 0.5 * 1.5 / 2.5)
    back = Canopy.from_dict(c.to_dict(), rows)
    assert back.hedges == c.hedges and back.profile == c.profile


def test_row_heights_from_a_surface_model():
    # ridges 0.7 m high and 0.6 m wide every 2 m on a ground sloping 5 %: the CHM removes the slope
    def surface(x, y):
        ground = 0.05 * y
        return ground + np.where(np.abs(((x + 1.0) % 2.0) - 1.0) < 0.3, 0.7, 0.0)

    rows = [[(float(x), 0.0), (float(x), 20.0)] for x in (0.0, 2.0, 4.0)]
    h = measure_row_heights(surface, rows, 0.6, 2.0)
    assert h == pytest.approx([0.7, 0.7, 0.7], abs=1e-9)


# ---------------------------------------------------------------- interception
def test_impaction_efficiency_curve():
    assert impaction_efficiency(0.0) == 0.0
    assert impaction_efficiency(0.8) == pytest.approx(0.25)
    e = impaction_efficiency(np.logspace(-2, 3, 50))
    assert np.all(np.diff(e) > 0) and e[-1] > 0.99
    # St = τ U / L with τ = v_t / g
    assert stokes_number(0.05, 4.0, 0.1) == pytest.approx(2.0)


def test_semicircle_cdf_is_the_disc_cross_section():
    u = np.linspace(-1, 1, 20001)
    dens = np.sqrt(1 - u * u) * 2 / np.pi
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(u))])
    assert semicircle_cdf(u) == pytest.approx(cum, abs=1e-6)
    assert semicircle_cdf(-3.0) == 0.0 and semicircle_cdf(3.0) == 1.0


def test_leaf_area_on_path_geometry():
    prof = np.array([1.0])
    # vertical through the hedge: LAD x depth; beside it: nothing
    assert leaf_area_on_path(0.1, 0.0, 0.5, 0.5, 2.0, 4.0, prof) == pytest.approx(6.0)
    assert leaf_area_on_path(0.3, 0.0, 0.5, 0.5, 2.0, 4.0, prof) == 0.0
    # slope k: the path crosses the width w in a height w/|k| (here 0.5 m, inside the foliage)
    assert leaf_area_on_path(1.25, 1.0, 0.5, 0.5, 2.0, 4.0, prof) == pytest.approx(4.0 * 0.5)
    # a profile weights the layers: all leaves in the top half
    assert leaf_area_on_path(0.0, 0.0, 0.5, 0.0, 2.0, 4.0, np.array([0.0, 2.0])) == pytest.approx(8.0)
    assert leaf_area_on_path(0.75, 1.0, 0.5, 0.0, 2.0, 4.0, np.array([0.0, 2.0])) == pytest.approx(0.0)


def test_capture_fraction_vertical_drops_is_beer_lambert_over_the_band():
    r, w, b, h, lad, g, e = 1.5, 0.5, 0.5, 2.0, 4.0, 0.5, 0.6
    got = capture_fraction(0.2, r, 0.0, 1.0, e, g, w, b, h, lad, np.array([1.0]), nodes=8)
    band = semicircle_cdf((0.25 - 0.2) / r) - semicircle_cdf((-0.25 - 0.2) / r)
    assert got == pytest.approx(band * (1 - math.exp(-g * e * lad * (h - b))), abs=2e-6)
    # a denser hedge captures more, a parcel far from it nothing
    assert capture_fraction(0.2, r, 0.0, 1.0, e, g, w, b, h, 2 * lad, np.array([1.0])) > got
    assert capture_fraction(3.0, r, 0.0, 1.0, e, g, w, b, h, lad, np.array([1.0])) == 0.0


def test_capture_fraction_slanted_path_converges_with_nodes():
    args = dict(s_c=0.4, radius=1.2, k=0.6, sec=math.sqrt(1 + 0.36), eff=0.5, g_factor=0.5, width=0.5, base=0.5,
                top=2.0, lad=4.0, profile=np.array([0.5, 1.0, 1.5]))
    fine = capture_fraction(**args, nodes=400)
    assert capture_fraction(**args, nodes=8) == pytest.approx(fine, rel=0.03)
    assert 0.0 < fine < 1.0


# ---------------------------------------------------------------- evaporation
def test_wet_bulb_and_vapour_pressure():
    assert wet_bulb_c(20.0, 50.0) == pytest.approx(13.7, abs=0.1)  # Stull 2011, Fig. 1 example
    assert wet_bulb_c(25.0, 100.0) == pytest.approx(25.0, abs=0.3)
    assert saturation_vapour_pressure_pa(20.0) == pytest.approx(2339.0, rel=0.005)  # 23.39 hPa


@pytest.mark.parametrize(("t_c", "rh"), [(15.0, 70.0), (20.0, 50.0), (20.0, 80.0)])
def test_d2_law_against_the_spray_rule_of_thumb(t_c, rh):
    # Amsden 1962: lifetime d²/(80 ΔT) s (d µm, ΔT the wet-bulb depression): λ ≈ 80 ΔT µm²/s in still air,
    # a rule for temperate spraying weather (15-20 °C: the law and the rule agree within 25 %)
    lam = float(evaporation_constant(np.array([100e-6]), np.array([0.0]), t_c, rh, ventilation=False)[0]) * 1e12
    assert lam == pytest.approx(80.0 * (t_c - wet_bulb_c(t_c, rh)), rel=0.25)
    # falling drops evaporate faster (ventilation)
    assert evaporation_constant(np.array([100e-6]), np.array([0.25]), t_c, rh)[0] > lam * 1e-12


def test_evaporation_per_kelvin_of_depression_rises_with_temperature():
    # the saturation vapour density grows faster than linearly with temperature (Clausius-Clapeyron): the
    # constant-80 rule underestimates hot weather (30 °C, 40 %: the law's λ is ~1.5x the rule's)
    per_k = [float(evaporation_constant(np.array([100e-6]), np.array([0.0]), t, 50.0, ventilation=False)[0])
             / (t - wet_bulb_c(t, 50.0)) for t in (10.0, 20.0, 30.0)]
    assert per_k[0] < per_k[1] < per_k[2]


def test_remaining_fraction():
    d0, lam = 100e-6, 5e-10
    life = d0 * d0 / lam
    assert remaining_fraction(d0, lam, 0.0) == 1.0
    assert remaining_fraction(d0, lam, 0.5 * life) == pytest.approx(0.5 ** 1.5)
    assert remaining_fraction(d0, lam, 2 * life) == 0.0


# ---------------------------------------------------------------- drift
def test_field_split_conserves_and_places():
    rows = [[(0.0, 0.0), (0.0, 40.0)], [(2.0, 0.0), (2.0, 40.0)]]
    f = field_polygon(rows, 2.0, np.zeros((0, 2)), 1.0)
    assert f.area == pytest.approx(4.0 * 40.0, rel=1e-3)  # -1 .. 3 m across
    x = np.array([1.0, 3.0, 8.0, 200.0])
    y = np.full(4, 20.0)
    vol = np.ones(4)
    inf, off, out = field_split(f, 50.0, x, y, np.full(4, 1.0), vol)
    assert inf + off + out == pytest.approx(vol)
    assert inf[0] == pytest.approx(1.0) and inf[1] == pytest.approx(0.5)  # centre on the edge: half in
    assert off[2] == pytest.approx(1.0) and out[3] == pytest.approx(1.0)


def test_drift_curve_of_a_uniform_deposit_is_its_rate():
    rows = [[(0.0, 0.0), (0.0, 40.0)], [(2.0, 0.0), (2.0, 40.0)]]
    f = field_polygon(rows, 2.0, np.zeros((0, 2)), 1.0)
    frames, calm = drift_frames(rows, f, (2.0, 0.0))
    assert not calm and frames[0].normal == pytest.approx((1.0, 0.0)) and frames[0].row == 1
    # parcels of 1e-4 L every 0.1 m x 0.1 m east of the last row: 0.01 L/m² = 100 L/ha
    gx, gy = np.meshgrid(np.arange(2.05, 40.0, 0.1), np.arange(0.05, 40.0, 0.1))
    vol = np.full(gx.size, 1e-4)
    curve = drift_curve(frames, gx.ravel(), gy.ravel(), np.full(gx.size, 1e-3), vol, 100.0, [3.0, 10.0])
    assert [c["percent_of_applied"] for c in curve] == pytest.approx([100.0, 100.0], rel=1e-6)
    frames, calm = drift_frames(rows, f, (0.0, 0.05))
    assert calm and len(frames) == 2 and {fr.row for fr in frames} == {0, 1}
