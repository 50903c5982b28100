"""Wind laws: constant, sinusoid, 1-cosine gust, sums, spatial shear and Dryden turbulence."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vinecli.flight.dryden import W20_MPS, DrydenTurbulence, low_altitude_parameters
from vinecli.flight.wind import heading_unit_enu, make_wind
from vinecli.specs.wind import (
    ConstantWind,
    DrydenWind,
    GustWind,
    SinusoidWind,
    SpatialShear,
    SumWind,
    WindSpec,
)


def test_headings() -> None:
    assert heading_unit_enu(90.0) == pytest.approx((1.0, 0.0, 0.0), abs=1e-12)  # towards east
    assert heading_unit_enu(0.0) == pytest.approx((0.0, 1.0, 0.0), abs=1e-12)  # towards north
    assert heading_unit_enu(225.0) == pytest.approx((-math.sqrt(0.5), -math.sqrt(0.5), 0.0), abs=1e-12)


def test_constant() -> None:
    w = make_wind(WindSpec(law=ConstantWind(velocity_enu=(1.0, -2.0, 0.5))), seed=0)
    assert w.velocity(0.0, (0.0, 0.0, 0.0)) == (1.0, -2.0, 0.5)
    assert w.velocity(123.4, (50.0, 3.0, 10.0)) == (1.0, -2.0, 0.5)
    assert w.is_constant


def test_sinusoid_matches_formula() -> None:
    law = SinusoidWind(mean_mps=3.0, amplitude_mps=1.5, period_s=8.0, phase_rad=0.3, heading_deg=0.0)
    w = make_wind(WindSpec(law=law), seed=1)
    for t in np.linspace(0.0, 20.0, 57):
        expected = 3.0 + 1.5 * math.sin(2 * math.pi * t / 8.0 + 0.3)
        v = w.velocity(float(t), (0.0, 0.0, 5.0))
        assert v == pytest.approx((0.0, expected, 0.0), abs=1e-12)  # towards north, no vertical part
    # start time: zero before, the law (phase counted from the start) after
    late = make_wind(WindSpec(law=SinusoidWind(mean_mps=2.0, amplitude_mps=1.0, period_s=4.0, start_s=5.0)), seed=1)
    assert late.velocity(4.99) == (0.0, 0.0, 0.0)
    assert late.velocity(6.0)[0] == pytest.approx(2.0 + math.sin(2 * math.pi * 1.0 / 4.0))


def test_gust_peak_and_duration() -> None:
    law = GustWind(peak_mps=6.0, start_s=2.0, duration_s=3.0, heading_deg=90.0, vertical_mps=-1.0)
    w = make_wind(WindSpec(law=law), seed=0)
    assert w.velocity(1.99) == (0.0, 0.0, 0.0)
    assert w.velocity(2.0) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    peak = w.velocity(3.5)
    assert peak == pytest.approx((6.0, 0.0, -1.0), abs=1e-12)
    assert w.velocity(5.0) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    assert w.velocity(5.01) == (0.0, 0.0, 0.0)
    ts = np.arange(0.0, 8.0, 0.001)
    vx = np.array([w.velocity(float(t))[0] for t in ts])
    assert vx.max() == pytest.approx(6.0, abs=1e-4)
    nonzero = ts[vx > 1e-9]
    assert nonzero[-1] - nonzero[0] == pytest.approx(3.0, abs=0.003)
    assert w.velocity(2.75)[0] == pytest.approx(3.0 * (1 - math.cos(2 * math.pi * 0.75 / 3.0)))


def test_sum_and_spatial_shear() -> None:
    law = SumWind(
        terms=[
            ConstantWind(velocity_enu=(2.0, 0.0, 0.0)),
            GustWind(peak_mps=4.0, start_s=0.0, duration_s=2.0, heading_deg=0.0),
        ]
    )
    w = make_wind(WindSpec(law=law), seed=0)
    assert w.velocity(1.0) == pytest.approx((2.0, 4.0, 0.0), abs=1e-12)
    sheared = make_wind(
        WindSpec(
            law=ConstantWind(velocity_enu=(3.0, 0.0, 0.0)),
            spatial=SpatialShear(reference_height_m=6.0, shear_exponent=1 / 7),
        ),
        seed=0,
    )
    assert sheared.velocity(0.0, (0.0, 0.0, 6.0))[0] == pytest.approx(3.0)
    assert sheared.velocity(0.0, (0.0, 0.0, 24.0))[0] == pytest.approx(3.0 * 4 ** (1 / 7))
    assert sheared.velocity(0.0, (0.0, 0.0, 1.0))[0] < 3.0
    grad = make_wind(
        WindSpec(law=ConstantWind(velocity_enu=(2.0, 0.0, 0.0)), spatial=SpatialShear(gradient_per_m=(0.01, 0.0, 0.0))),
        seed=0,
    )
    assert grad.velocity(0.0, (50.0, 0.0, 3.0))[0] == pytest.approx(2.0 * 1.5)


def test_mil_8785c_parameters() -> None:
    # at 1000 ft the low-altitude forms meet the medium-altitude ones: L = 1000 ft, σ_u = σ_v = σ_w
    (lu, lv, lw), (su, sv, sw) = low_altitude_parameters(1000 * 0.3048, W20_MPS["moderate"])
    assert lu == pytest.approx(304.8) and lv == pytest.approx(304.8) and lw == pytest.approx(304.8)
    assert su == pytest.approx(sw) and sw == pytest.approx(0.1 * 30 * 0.514444)
    # at 20 ft: L_w = 20 ft, L_u = 20/(0.177 + 0.000823·20)^1.2 ft, σ_u/σ_w = 1/(0.177 + 0.01646)^0.4
    (lu, _, lw), (su, _, sw) = low_altitude_parameters(20 * 0.3048, 10.0)
    k = 0.177 + 0.000823 * 20
    assert lw == pytest.approx(20 * 0.3048)
    assert lu == pytest.approx(20 / k**1.2 * 0.3048)
    assert su / sw == pytest.approx(1 / k**0.4)
    assert sw == pytest.approx(1.0)


def _dryden_series(seed: int, n: int, **kw: object) -> np.ndarray:
    law = DrydenWind(**kw)  # type: ignore[arg-type]
    w = make_wind(WindSpec(law=law), seed=seed, dt=0.01)
    return np.array([w.velocity(k * 0.01) for k in range(n)])


def test_dryden_deterministic_and_seeded() -> None:
    a = _dryden_series(7, 2000, intensity="light")
    b = _dryden_series(7, 2000, intensity="light")
    c = _dryden_series(8, 2000, intensity="light")
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)
    d = _dryden_series(7, 2000, intensity="light", seed_offset=1)
    assert not np.allclose(a, d)


def test_dryden_independent_of_query_pattern() -> None:
    law = WindSpec(law=DrydenWind(intensity="moderate", mean_mps=2.0))
    dense = make_wind(law, seed=3, dt=0.004)
    sparse = make_wind(law, seed=3, dt=0.004)
    dense_vals = {k: dense.velocity(k * 0.001) for k in range(0, 5001)}  # 1 kHz queries
    for k in range(0, 5001, 250):  # 4 Hz queries
        assert sparse.velocity(k * 0.001) == dense_vals[k]
    # held between filter steps
    assert dense_vals[4] == dense_vals[5] == dense_vals[7]


def test_dryden_statistics_match_sigma_and_time_constant() -> None:
    dt = 0.02
    sigma = (1.0, 0.8, 0.5)
    length = (10.0, 10.0, 4.0)
    v = 5.0
    rng = np.random.default_rng(11)
    turb = DrydenTurbulence(sigma, length, v, dt, rng)
    n = 200_000  # 4000 s, 2000 longitudinal time constants
    x = np.array([turb.step() for _ in range(n)])
    assert x.mean(axis=0) == pytest.approx((0, 0, 0), abs=0.1)
    np.testing.assert_allclose(x.std(axis=0), sigma, rtol=0.15)
    t_u = length[0] / v
    lag = round(t_u / dt)
    u = x[:, 0] - x[:, 0].mean()
    rho = float(np.dot(u[:-lag], u[lag:]) / np.dot(u, u))
    assert rho == pytest.approx(math.exp(-1.0), abs=0.06)  # autocorrelation e^{-τ/T}, T = L/V
    # lateral: R(τ) = σ²(1 - τ/2T) e^{-τ/T} crosses zero at τ = 2T
    vv = x[:, 1] - x[:, 1].mean()
    t_v = length[1] / v
    r1 = float(np.dot(vv[: -round(t_v / dt)], vv[round(t_v / dt) :]) / np.dot(vv, vv))
    assert r1 == pytest.approx(0.5 * math.exp(-1.0), abs=0.06)
    r2 = float(np.dot(vv[: -round(2 * t_v / dt)], vv[round(2 * t_v / dt) :]) / np.dot(vv, vv))
    assert abs(r2) < 0.06
    # PSD of u: half-power (corner) frequency near V/(2π L) for the first-order spectrum
    spec = np.abs(np.fft.rfft(u.reshape(50, -1), axis=1)) ** 2
    psd = spec.mean(axis=0)
    f = np.fft.rfftfreq(u.size // 50, dt)
    low = psd[1:4].mean()
    corner = f[np.argmax(psd < low / 2)]
    assert corner == pytest.approx(v / (2 * math.pi * length[0]), rel=0.35)


def test_dryden_wind_axes_follow_heading() -> None:
    x = _dryden_series(5, 30000, mean_mps=4.0, heading_deg=0.0, sigma_mps=1.0, altitude_m=10.0)
    # mean wind towards north, turbulence on every axis
    assert x[:, 1].mean() == pytest.approx(4.0, abs=0.5)
    assert abs(x[:, 0].mean()) < 0.5
    assert x[:, 0].std() > 0.5 and x[:, 1].std() > 0.5 and x[:, 2].std() > 0.1
    (_, _, lw), (su, _, sw) = low_altitude_parameters(10.0, 1.0)
    assert x[:, 2].std() == pytest.approx(sw / su, rel=0.25)


def test_dryden_terms_in_a_sum_are_independent_and_sigma_override() -> None:
    law = SumWind(terms=[DrydenWind(sigma_mps=1.0), DrydenWind(sigma_mps=1.0)])
    w = make_wind(WindSpec(law=law), seed=9, dt=0.01)
    a, b = (t.turb for t in w.terms)
    xa = np.array([a.step() for _ in range(3000)])
    xb = np.array([b.step() for _ in range(3000)])
    assert not np.allclose(xa, xb)
    assert w.terms[0].params["sigma_mps"][0] == 1.0
    (_, _, _), (su, _, sw) = low_altitude_parameters(5.0, 1.0)
    assert w.terms[0].params["sigma_mps"][2] == pytest.approx(sw / su)
    calm = make_wind(WindSpec(law=DrydenWind()), seed=1)  # no intensity, no mean: no turbulence
    assert calm.velocity(3.0) == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("T", [0.05, 0.7, 12.0, 400.0])
def test_dryden_second_order_closed_form_equals_the_general_solvers(T: float) -> None:
    """Φ, the stationary covariance and the noise factor of (1 + √3 T s)/(1 + T s)² equal scipy's
    matrix exponential and Lyapunov solver (the closed form avoids importing scipy at start-up)."""
    from scipy.linalg import expm, solve_continuous_lyapunov

    from vinecli.flight.dryden import _second_order

    dt = 0.004
    a = np.array([[0.0, 1.0], [-1.0 / T**2, -2.0 / T]])
    b = np.array([[0.0], [1.0]])
    p = solve_continuous_lyapunov(a, -b @ b.T)
    phi_ref = expm(a * dt)
    phi, lq, c, lp = (np.array(m) for m in _second_order(T, dt))
    assert np.allclose(phi, phi_ref, rtol=1e-12, atol=1e-15)
    scale = float(np.abs(p).max())  # the solver's and the cancellation's error are relative to |p|
    assert np.allclose(lp @ lp.T, p, rtol=1e-10, atol=1e-13 * scale)
    q_ref = p - phi_ref @ p @ phi_ref.T
    assert np.allclose(lq @ lq.T, q_ref, rtol=1e-6, atol=1e-12 * scale)
    assert c @ (lp @ lp.T) @ c == pytest.approx(1.0, rel=1e-12)  # unit output variance
