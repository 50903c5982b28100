"""Validation of the spray transport model (docs/deposition.md), closed forms and published bands.

Records are built by hand as the loop emits them (EMIT_COLUMNS) at 250 Hz over flat ground.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vinecli.specs.sprayer import DropletSpectrumSpec, NozzleSpec, SprayerSpec
from vinecli.specs.wind import WindSpec
from vinecli.spray.deposit_grid import GridSpec, flat_height, grid_for, rasterise, rasterise_discs
from vinecli.spray.deposition import EMIT_COLUMNS, DepositionConfig, SprayerGeometry, transport
from vinecli.spray.droplets import terminal_velocity
from vinecli.vehicle import load_vehicle

DT = 0.004
RHO = 1.204
FLAT = flat_height(0.0)
NO_DW = DepositionConfig(downwash=False, diffusion=False)
CONE = DepositionConfig(downwash=False, diffusion=False, drag_reach=False)  # drops fly on along the cone


def one_nozzle(cone_deg: float = 80.0, vmd_um: float = 200.0, gsd: float = 1.5, classes: int = 5) -> SprayerGeometry:
    veh = load_vehicle("x500-sprayer")
    sp = SprayerSpec(nozzles=[NozzleSpec(position_m=(0.0, 0.0, -0.1), cone_angle_deg=cone_deg)],
                     droplets=DropletSpectrumSpec(vmd_um=vmd_um, gsd=gsd, classes=classes))
    return SprayerGeometry.from_vehicle(veh.model_copy(update={"sprayer": sp}), RHO)


def records(seconds: float, z_com: float, flow_lps: float, wind_x: float = 0.0, speed: float = 0.0,
            thrust_n: float = 32.6) -> np.ndarray:
    """Level flight (or hover) along +x at ``speed`` with the CoM at ``z_com`` over flat ground at z = 0."""
    n = int(round(seconds / DT))
    r = np.zeros((n, len(EMIT_COLUMNS)))
    t = np.arange(n) * DT
    r[:, 0] = t
    r[:, 1] = speed * t
    r[:, 3] = z_com
    r[:, 7] = 1.0  # identity attitude
    r[:, 8] = speed
    r[:, 11] = wind_x
    r[:, 14] = thrust_n
    r[:, 15] = flow_lps * DT
    return r


def deposit(rec: np.ndarray, geo: SprayerGeometry, cfg: DepositionConfig, cell: float = 0.05,
            margin: float = 30.0) -> tuple[np.ndarray, GridSpec, float, float, object]:
    par = transport(rec, geo, FLAT, WindSpec(), RHO, seed=0, config=cfg)
    grid = grid_for(par.path_xy, [], (-500.0, -500.0, 500.0, 500.0), cell, margin, 20_000_000)
    vol, off = rasterise_discs(grid, par.x, par.y, par.vol, par.radius)
    return vol, grid, off, par.emitted_l, par


def centroid(vol: np.ndarray, grid: GridSpec) -> tuple[float, float]:
    xc, yc = grid.centres()
    s = vol.sum()
    return float((vol.sum(axis=0) * xc).sum() / s), float((vol.sum(axis=1) * yc).sum() / s)


def test_hover_no_wind_no_downwash_lands_under_the_nozzle_on_the_cone_footprint() -> None:
    h = 2.0  # nozzle height: CoM 2.1 m, nozzle 0.1 m below
    geo = one_nozzle(cone_deg=80.0)
    vol, grid, off, em, _ = deposit(records(4.0, h + 0.1, 0.02), geo, CONE)
    assert em == pytest.approx(4.0 * 0.02)
    assert abs(em - vol.sum() - off) / em <= 1e-6
    assert off == pytest.approx(0.0, abs=1e-12)
    cx, cy = centroid(vol, grid)
    assert math.hypot(cx, cy) < 0.01
    wet = (vol > 1e-3 * vol.max()).sum() * grid.cell ** 2
    diameter = 2.0 * math.sqrt(wet / math.pi)
    expected = 2.0 * h * math.tan(math.radians(40.0))
    assert abs(diameter - expected) / expected < 0.10, (diameter, expected)


def test_drag_stops_the_drops_within_their_ballistic_reach() -> None:
    """Hover, no wind, no downwash: each class lands on a disc of its ballistic reach (Schiller–Naumann drag from
    the nozzle's exit speed, spray/wake.py), at most the cone; the reach grows with the drop size."""
    from vinecli.spray.wake import ballistic_reach_m

    h = 2.0
    geo = one_nozzle(cone_deg=80.0, vmd_um=200.0, gsd=1.5, classes=5)
    par = transport(records(0.2, h + 0.1, 0.02), geo, FLAT, WindSpec(), RHO, seed=0, config=NO_DW)
    # the drops fly along the cone's rays at the exit speed (drag on their whole speed), sideways by sin(θ/2)
    side = math.sin(math.radians(40.0))
    expected = np.minimum(side * ballistic_reach_m(geo.diam_m, geo.exit_speed_mps, RHO),
                          h * math.tan(math.radians(40.0)))
    got = par.radius.reshape(-1, geo.diam_m.size)
    assert np.allclose(got, expected[None, :], rtol=1e-9)
    assert np.all(np.diff(expected) > 0) and expected[0] < 0.5 * h * math.tan(math.radians(40.0))
    # the same reach by a fine time integration of the drag law
    d, v0 = 200e-6, geo.exit_speed_mps
    tau, x, v, dt = 998.2 * d * d / (18 * 1.81e-5), 0.0, v0, 1e-6
    while v > 1e-4 * v0:
        v -= v * (1 + 0.15 * (RHO * v * d / 1.81e-5) ** 0.687) / tau * dt
        x += v * dt
    assert float(ballistic_reach_m(np.array([d]), v0, RHO)[0]) == pytest.approx(x, rel=0.01)


@pytest.mark.parametrize("u", [1.0, 3.0])
def test_crosswind_shift_is_u_times_fall_time(u: float) -> None:
    h, d = 2.0, 150e-6
    geo = one_nozzle(vmd_um=150.0, gsd=1.0, classes=1)
    vol, grid, off, em, _ = deposit(records(2.0, h + 0.1, 0.02, wind_x=u), geo, NO_DW)
    assert abs(em - vol.sum() - off) / em <= 1e-6
    cx, cy = centroid(vol, grid)
    expected = u * h / float(terminal_velocity(d)[0])
    assert abs(cx - expected) / expected < 0.05, (cx, expected)
    assert abs(cy) < 0.01


def test_downwash_reduces_the_shift_and_it_grows_with_wind() -> None:
    geo = one_nozzle(vmd_um=200.0, gsd=1.5, classes=5)
    winds = [1.0, 2.0, 3.0, 4.0, 5.0]
    with_dw, without = [], []
    for u in winds:
        for cfg, out in ((DepositionConfig(diffusion=False), with_dw), (NO_DW, without)):
            vol, grid, _off, _em, _par = deposit(records(1.0, 2.1, 0.02, wind_x=u), geo, cfg)
            # the deposit's centroid on the map (the far field's share still airborne at its reach is put 10 km away)
            out.append(centroid(vol, grid)[0])
    assert all(a < b for a, b in zip(with_dw, without, strict=True))
    assert all(b > a for a, b in zip(with_dw[:-1], with_dw[1:], strict=True))
    assert with_dw[-1] < 0.5 * without[-1]


def test_straight_pass_mean_rate_across_the_swath_is_q_over_v_swath() -> None:
    q, v, h = 0.02, 2.0, 2.0
    geo = one_nozzle(cone_deg=80.0)
    vol, grid, off, em, _ = deposit(records(20.0, h + 0.1, q, speed=v), geo, DepositionConfig())
    assert abs(em - vol.sum() - off) / em <= 1e-6
    swath = 2.0 * h * math.tan(math.radians(40.0))
    xc, yc = grid.centres()
    mid = (xc > 10.0) & (xc < 30.0)  # away from the start and the end of the pass
    rate = vol[:, mid].mean(axis=1) * 1e4 / grid.cell ** 2  # cross-track profile, L/ha
    inside = np.abs(yc) <= swath / 2
    mean_rate = float(rate[inside].mean())
    expected = 1e4 * q / (v * swath)
    assert abs(mean_rate - expected) / expected < 0.05, (mean_rate, expected)


def test_drones_2022_band_pattern_shift_in_crosswind() -> None:
    # Drones 2022, 6(8):204 (wind tunnel, a sprayer-class multirotor hovering with 2 and 10 L of payload): at
    # 1.5-4.5 m/s crosswind the pattern under the drone shifts by tenths of a metre up to ~2 m. The pattern is what
    # lands under the vehicle (a +-5 m patternator here); the share the crosswind strips from the wake's edge lands
    # further downwind (far field) and is not part of it.
    veh = load_vehicle("ag-hexa-16")
    geo = SprayerGeometry.from_vehicle(veh, RHO)
    for payload_kg in (2.0, 10.0):
        thrust = 9.81 * (veh.frame.mass_kg + veh.n_rotors * veh.motor.rotor_mass_kg + payload_kg)
        shifts = []
        for u in (1.5, 3.0, 4.5):
            vol, grid, _off, _em, _par = deposit(records(1.0, 2.1, 0.02, wind_x=u, thrust_n=thrust), geo,
                                                 DepositionConfig(diffusion=False))
            xc, _yc = grid.centres()
            profile, window = vol.sum(axis=0), np.abs(xc) <= 5.0
            shifts.append(float((profile[window] * xc[window]).sum() / profile[window].sum()))
        assert 0.1 <= shifts[0] and shifts[-1] <= 2.0, shifts
        assert shifts == sorted(shifts)


def test_volume_leaving_the_grid_is_counted() -> None:
    geo = one_nozzle(vmd_um=100.0, gsd=1.0, classes=1)
    par = transport(records(2.0, 2.1, 0.02, wind_x=4.0), geo, FLAT, WindSpec(), RHO, 0, NO_DW)
    small = GridSpec(-2.0, -2.0, 0.1, 60, 40)  # ends at x = 4 m; the drops drift ~30 m
    vol, off = rasterise_discs(small, par.x, par.y, par.vol, par.radius)
    assert off > 0.5 * par.emitted_l
    assert abs(par.emitted_l - vol.sum() - off) / par.emitted_l <= 1e-6
    v2, off2 = rasterise(small, np.array([0.0, 100.0]), np.array([0.0, 0.0]), np.array([1.0, 2.0]))
    assert v2.sum() == pytest.approx(1.0) and off2 == pytest.approx(2.0)


def test_transport_is_deterministic_per_seed_with_diffusion() -> None:
    geo = one_nozzle()
    rec = records(1.0, 2.1, 0.02, wind_x=3.0)
    a = transport(rec, geo, FLAT, WindSpec(), RHO, 7, DepositionConfig())
    b = transport(rec, geo, FLAT, WindSpec(), RHO, 7, DepositionConfig())
    c = transport(rec, geo, FLAT, WindSpec(), RHO, 8, DepositionConfig())
    assert np.array_equal(a.x, b.x) and np.array_equal(a.y, b.y)
    assert not np.array_equal(a.x, c.x)


def test_records_summed_over_steps_land_where_the_single_steps_do() -> None:
    # the loop sums up to 10 steps per record and stamps it with the last step's state and the mean lag
    geo = one_nozzle()
    step = records(10.0, 2.1, 0.02, speed=2.0)
    grouped = step[9::10].copy()
    grouped[:, 15] = 10 * 0.02 * DT
    grouped[:, 16] = 4.5 * DT
    a = transport(step, geo, FLAT, WindSpec(), RHO, 0, NO_DW)
    b = transport(grouped, geo, FLAT, WindSpec(), RHO, 0, NO_DW)
    assert a.emitted_l == pytest.approx(b.emitted_l, rel=1e-12)
    ca = float(np.dot(a.x, a.vol) / a.vol.sum())
    cb = float(np.dot(b.x, b.vol) / b.vol.sum())
    assert abs(ca - cb) < 0.005


def test_a_disc_wider_than_its_reach_of_the_grid_changes_nothing_on_it() -> None:
    # far-field parcels spread over discs ~100 m wide that land too far away to touch the map: they leave the grid's
    # deposit as it was (within FFT round-off; their width no longer sizes the convolution) and their volume is
    # counted off the grid; one that does reach it adds its uniform share on every cell

    grid = GridSpec(-5.0, -5.0, 0.05, 200, 200)
    x, y = np.array([0.0, 1.0]), np.array([0.0, -0.5])
    vol, rad = np.array([1e-3, 2e-3]), np.array([0.3, 0.8])
    base, off0 = rasterise_discs(grid, x, y, vol, rad)
    far_x, far_y = np.array([120.0, 3.0]), np.array([0.0, -160.0])
    more, off1 = rasterise_discs(grid, np.concatenate([x, far_x]), np.concatenate([y, far_y]),
                                 np.concatenate([vol, [5e-4, 7e-4]]), np.concatenate([rad, [50.0, 45.0]]))
    assert np.abs(more - base).max() <= 1e-12 * base.max()
    assert off1 - off0 == pytest.approx(1.2e-3, rel=1e-9)
    assert base.sum() + off0 == pytest.approx(vol.sum(), rel=1e-12)
    reach, off2 = rasterise_discs(grid, np.append(x, 40.0), np.append(y, 0.0), np.append(vol, 5e-4),
                                  np.append(rad, 50.0))
    uniform = 5e-4 * grid.cell ** 2 / (math.pi * 50.0 ** 2)  # its disc covers the whole 10 m map
    assert np.allclose(reach - base, uniform, rtol=0.02, atol=0.0)
    assert reach.sum() + off2 == pytest.approx(vol.sum() + 5e-4, rel=1e-12)
