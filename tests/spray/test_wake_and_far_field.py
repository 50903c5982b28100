"""The rotor wake's footprint (spray/wake.py) and the far-field drift through the surface layer
(spray/surface_layer.py, spray/outwash.py) against closed forms and their limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vinecli.spray.droplets import terminal_velocity
from vinecli.spray.interception import capture_fraction
from vinecli.spray.outwash import BEYOND_M, lifted_parcels
from vinecli.spray.surface_layer import KARMAN, SurfaceLayer, landing_bands
from vinecli.spray.wake import (
    JET_EDDY_VISCOSITY,
    ballistic_reach_m,
    exit_speed_mps,
    footprint_radius_m,
    mean_speed_through_foliage,
    plume_radius_at,
    wake_half_width_m,
    wake_spread_sigma_m,
)


def test_exit_speed_is_bernoulli() -> None:
    assert exit_speed_mps(3.0) == pytest.approx(math.sqrt(2 * 3e5 / 998.2))
    assert exit_speed_mps(0.0) == 0.0


def test_ballistic_reach_grows_with_size_and_speed_and_is_stokes_for_tiny_drops() -> None:
    d = np.array([50e-6, 100e-6, 200e-6, 400e-6])
    r10, r20 = ballistic_reach_m(d, 10.0), ballistic_reach_m(d, 20.0)
    assert np.all(np.diff(r10) > 0) and np.all(r20 > r10)
    # Stokes drag (Re -> 0): the reach is V tau_St
    tiny, v = np.array([5e-6]), 0.01
    tau = 998.2 * tiny[0] ** 2 / (18 * 1.81e-5)
    assert float(ballistic_reach_m(tiny, v)[0]) == pytest.approx(v * tau, rel=5e-3)  # Re 0.003: 0.15 % above Stokes


def test_the_footprint_disc_has_the_variance_of_reach_and_spreading() -> None:
    # a uniform disc of radius r has variance r^2/4 along an axis: disc(reach) + Gaussian(sigma) -> sqrt(r^2 + 4 s^2)
    r = footprint_radius_m(np.array(0.3), np.array(0.2))
    assert float(r) ** 2 / 4 == pytest.approx(0.3 ** 2 / 4 + 0.2 ** 2)
    # the round jet's eddy viscosity 0.028 U r_half: sigma^2 = 2 nu_T t = 0.056 r_half s
    half = wake_half_width_m(0.267, 6)  # M600: six 21 in rotors
    assert half == pytest.approx(0.267 * math.sqrt(3.0))
    assert float(wake_spread_sigma_m(half, np.array(2.7))) ** 2 == pytest.approx(2 * JET_EDDY_VISCOSITY * half * 2.7)
    # the plume: the reach at the nozzle's height, the full footprint on the ground
    reach, var, rad, rel = np.array([0.3]), np.array([0.28]), np.array([math.sqrt(0.09 + 0.28)]), np.array([2.8])
    assert float(plume_radius_at(reach, var, rad, rel, 2.8)[0]) == pytest.approx(0.3)
    assert float(plume_radius_at(reach, var, rad, rel, 0.0)[0]) == pytest.approx(rad[0])
    assert 0.3 < float(plume_radius_at(reach, var, rad, rel, 1.4)[0]) < rad[0]


def test_the_leaves_slow_the_wake() -> None:
    w = mean_speed_through_foliage(np.array([10.0, 10.0, 10.0]), np.array([0.0, 2.0, 8.0]))
    assert w[0] == pytest.approx(10.0)
    assert w[1] == pytest.approx(10.0 * (1 - math.exp(-0.4)) / 0.4)
    assert w[0] > w[1] > w[2]


def test_a_dense_hedge_catches_more_but_slows_the_spray_that_enters() -> None:
    # vertical drops of 150 um entering at 8 m/s of wake over a 0.55 m hedge, 1.7 m of foliage
    vt = float(terminal_velocity(150e-6)[0])
    args = dict(s_c=0.0, radius=0.2, k=0.0, sec=1.0, eff=0.0, g_factor=0.5, width=0.55, base=0.5, top=2.2,
                profile=np.array([1.0]), nodes=8)
    wake = (np.array(vt / 9.80665), np.array(0.0), np.array(vt), np.array(8.0), np.array(0.12))
    caught = [float(capture_fraction(lad=a, wake=wake, **args)) for a in (1.0, 4.6, 9.0)]
    assert caught[0] < caught[1] < caught[2] < 1.0
    # the same hedge with the wake at its entering speed throughout (no leaf drag) would catch more
    from vinecli.spray.interception import impaction_efficiency, stokes_number

    e_fast = float(impaction_efficiency(stokes_number(vt / 9.80665, vt + 8.0, 0.12)))
    no_drag = float(capture_fraction(lad=9.0, **{**args, "eff": e_fast}))
    assert caught[2] < no_drag


def test_the_log_wind_profile_and_stability() -> None:
    n = SurfaceLayer.from_wind(2.0, 3.0, 0.1)
    assert n.ustar == pytest.approx(KARMAN * 2.0 / math.log(30.0))
    assert float(n.wind(np.array(3.0))) == pytest.approx(2.0)
    assert float(n.sigma_w(np.array(1.0))) == pytest.approx(1.25 * n.ustar)
    assert float(n.diffusivity(np.array(2.0))) == pytest.approx(KARMAN * n.ustar * 2.0)
    stable, unstable = SurfaceLayer.from_wind(2.0, 3.0, 0.1, 20.0), SurfaceLayer.from_wind(2.0, 3.0, 0.1, -20.0)
    assert stable.ustar < n.ustar < unstable.ustar  # the same wind at 3 m: less mixing in stable air
    assert float(stable.diffusivity(np.array(2.0))) < float(n.diffusivity(np.array(2.0))) < float(
        unstable.diffusivity(np.array(2.0)))


def test_far_field_landing_conserves_and_moves_with_wind_size_and_stability() -> None:
    def mean_x(layer: SurfaceLayer, d: float) -> tuple[float, float]:
        vt = float(terminal_velocity(d)[0])
        m, x, _h, _t = landing_bands(layer, (vt, vt), 1.3, 250.0)
        assert m.sum() == pytest.approx(1.0) and np.all(m >= 0)
        landed = np.isfinite(x)
        return float(np.dot(m[landed], x[landed]) / m[landed].sum()), float(m[~landed].sum())

    weak, strong = SurfaceLayer.from_wind(1.0, 3.0, 0.1), SurfaceLayer.from_wind(3.0, 3.0, 0.1)
    assert mean_x(weak, 60e-6)[0] < mean_x(strong, 60e-6)[0]
    assert mean_x(strong, 100e-6)[0] < mean_x(strong, 60e-6)[0]
    assert mean_x(strong, 40e-6)[1] > mean_x(strong, 100e-6)[1]  # the finest still airborne at 250 m
    # deterministic: the same ensemble every time
    vt = float(terminal_velocity(60e-6)[0])
    a, b = landing_bands(strong, (vt, vt), 1.3, 250.0), landing_bands(strong, (vt, vt), 1.3, 250.0)
    assert all(np.array_equal(p, q) for p, q in zip(a, b, strict=True))


def test_in_calm_air_the_drops_settle_where_they_leave_the_wall_jet() -> None:
    # u* ~ 0: no wind, no turbulence: each drop falls straight down (within the density estimate's smoothing,
    # +-0.2 in ln x around its 5 cm floor) and lands after h / v_t
    layer = SurfaceLayer(1e-5, 0.1)
    vt = 0.2
    m, x, _h, t = landing_bands(layer, (vt, vt), 1.0, 250.0)
    landed = np.isfinite(x)
    assert m.sum() == pytest.approx(1.0) and m[~landed].sum() == 0.0
    assert float(np.dot(m[landed], x[landed])) < 0.1
    assert float(np.dot(m[landed], t[landed])) == pytest.approx((0.5 * (1.0 + 0.1) - 0.1) / vt, rel=0.05)


def test_lifted_parcels_keep_their_volume_and_go_downwind() -> None:
    vt = float(terminal_velocity(60e-6)[0])
    out = lifted_parcels(np.array([0.0]), np.array([0.0]), np.array([1.0]), np.array([[vt, vt]]), np.array([0.4]),
                         np.array([2.0]), np.array([0.0]), np.array([3.0]), 0.1, 1.3)
    assert out["vol"].sum() == pytest.approx(1.0)
    landed = out["x"] < BEYOND_M / 2
    assert np.all(out["x"][landed] >= 0.5 * 1.3 - 1e-9) and np.allclose(out["y"], 0.0)
    assert np.all(out["radius"] >= 0.5 * 1.3 - 1e-12)  # at least the wall jet's spread
    assert np.all(out["t_fall"] > 0.4)


def test_lifted_parcels_in_still_air_land_where_they_left_as_one_parcel() -> None:
    # nothing carries them away: every landing bin would fall on the same spot, so one parcel carries the volume
    # (the far field's merge window then stays short on calm missions: no lumps along the rows)
    vt = float(terminal_velocity(60e-6)[0])
    out = lifted_parcels(np.array([1.0, 5.0]), np.array([2.0, 2.0]), np.array([1.0, 0.5]),
                         np.array([[vt, vt], [vt, vt]]), np.array([0.4, 0.4]), np.zeros(2), np.zeros(2),
                         np.array([3.0, 3.0]), 0.1, 1.3)
    assert out["src"].tolist() == [0, 1]
    assert out["vol"] == pytest.approx([1.0, 0.5])
    assert out["x"] == pytest.approx([1.0, 5.0]) and out["y"] == pytest.approx([2.0, 2.0])
    assert out["radius"] == pytest.approx([0.65, 0.65])  # the release's own spread, the wall jet's W/2
    assert np.all(out["t_fall"] > 0.4)


def test_the_worlds_air_gives_the_stability() -> None:
    from pydantic import ValidationError

    from vinecli.specs.canopy import AirSpec

    assert AirSpec(temperature_c=20, relative_humidity_pct=60).obukhov_length_m is None  # neutral
    assert AirSpec(temperature_c=20, relative_humidity_pct=60, obukhov_length_m=-30).obukhov_length_m == -30
    with pytest.raises(ValidationError, match="obukhov_length_m"):
        AirSpec(temperature_c=20, relative_humidity_pct=60, obukhov_length_m=0.0)
    # the same drops released into the same 2 m/s wind: unstable air lofts more of them out of the 250 m the model
    # follows, stable air keeps them low (they settle nearer)
    vt = float(terminal_velocity(60e-6)[0])
    out, mean = [], []
    for length in (-10.0, math.inf, 10.0):
        m, x, _h, _t = landing_bands(SurfaceLayer.from_wind(2.0, 3.0, 0.1, length), (vt, vt), 1.3, 250.0)
        landed = np.isfinite(x)
        out.append(float(m[~landed].sum()))
        mean.append(float(np.dot(m[landed], x[landed]) / m[landed].sum()))
    assert out[0] > out[1] > out[2] >= 0.0
    assert mean[2] < mean[1]
