"""Validation of the PyBullet loop against closed-form physics.

Every test runs the real loop (run_simulation, real PyBullet) with an in-test open-loop
autopilot and compares recorded quantities with formulas.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from sim_helpers import AltitudeHold, OpenLoop, mission

from vinecli.autopilot.base import RunStatus
from vinecli.sim.runner import run_simulation
from vinecli.vehicle import load_vehicle

G = 9.80665


def _air(z: float, w: float | list[float] = 0.0, **state: object) -> dict[str, object]:
    """An open-loop phase starting in the air, skids ``z`` m above the terrain."""
    init = {"position_enu": [0.0, 0.0, z], **state}
    return {"type": "open_loop", "duration_s": 1000.0, "rotor_speeds_rad_s": w, "initial_state": init}


def test_hover_speed_matches_formula_with_full_tank(flat_world):
    """Collective-only PI (no mass knowledge): steady rotor speed = sqrt(m g / (n k_f)) within 0.5 %."""
    v = flat_world.vehicle
    m_total = v.dry_mass() + v.liquid_mass(v.tank.capacity_l)
    w_pred = math.sqrt(m_total * G / (v.n_rotors * v.motor.k_f))
    ap = AltitudeHold(v.n_rotors, w0=0.9 * w_pred, z_target=flat_world.spawn_enu[2] + 5.0)
    r = run_simulation(flat_world, mission([_air(5.0, 0.9 * w_pred)], max_duration_s=12.0), ap, seed=1)
    ts = r.timeseries
    late = ts["t_s"] > 8.0
    w_mean = np.mean([ts[f"rotor{i}_w_radps"][late] for i in range(1, 5)])
    assert r.metrics["total_mass_start_kg"] == pytest.approx(m_total)
    assert abs(w_mean - w_pred) / w_pred < 0.005
    assert np.abs(ts["acc_enu_z_mps2"][late]).max() < 0.05
    # the tank pushes with the liquid weight in a steady hover
    assert ts["tank_force_enu_z_n"][late].mean() == pytest.approx(-v.liquid_mass(1.0) * G, rel=0.005)


def test_open_loop_hover_command_keeps_altitude(flat_world):
    v = flat_world.vehicle
    w = v.hover_speed(v.dry_mass() + 1.0, G)
    r = run_simulation(flat_world, mission([_air(10.0, w)], max_duration_s=4.0), OpenLoop(lambda o: [w] * 4), seed=2)
    z = r.timeseries["pos_enu_z_m"]
    assert np.ptp(z) < 1e-3
    assert np.abs(r.timeseries["acc_enu_z_mps2"]).max() < 1e-3
    assert r.status is RunStatus.TIMEOUT


def test_free_fall_matches_half_g_t_squared(flat_world):
    """Motors off, no wind drag: z(t) = z0 - ½ g t² within 0.1 % of the fall (t ≥ 4 s), and exactly the
    symplectic-Euler solution z0 - ½ g t (t + dt) at every step before contact."""
    x500 = load_vehicle("x500").model_copy(update={"drag": {}})
    r = run_simulation(flat_world, mission([_air(150.0)], max_duration_s=5.0), OpenLoop(lambda o: [0.0] * 4),
                       seed=3, vehicle=x500)
    ts = r.timeseries
    t, z = ts["t_s"], ts["pos_enu_z_m"]
    z0 = z[0]
    drop = z0 - z
    dt = 1.0 / flat_world.physics_rate_hz
    assert np.allclose(drop, 0.5 * G * t * (t + dt), atol=1e-6)
    late = t >= 4.0
    assert np.all(np.abs(drop[late] - 0.5 * G * t[late] ** 2) / (0.5 * G * t[late] ** 2) < 1e-3)
    assert not ts["on_ground"].any()


def test_terminal_speed_with_wind_drag(flat_world):
    """Falling with drag on (base + tank links): v_terminal = sqrt(m g / c) within 1 %."""
    v = flat_world.vehicle
    c = sum(d.coefficient(flat_world.air_density) for d in v.drag.values())
    m = v.dry_mass()  # empty tank
    vt = math.sqrt(m * G / c)
    r = run_simulation(flat_world, mission([_air(400.0)], max_duration_s=14.0, tank_fill_l=0.0),
                       OpenLoop(lambda o: [0.0] * 4), seed=4)
    ts = r.timeseries
    assert abs(-ts["vel_enu_z_mps"][-1] - vt) / vt < 0.01
    # drag opposes the motion: points up while falling
    assert ts["drag_enu_z_n"][-1] == pytest.approx(m * G, rel=0.01)


@pytest.mark.parametrize("vel,wind", [((3.0, -1.0, 2.0), (1.0, 4.0, 0.0)), ((0.0, 0.0, 2.0), (0.0, 0.0, 0.0)),
                                      ((-2.0, 1.5, -1.0), (2.5, -3.0, 0.5))])
def test_drag_force_magnitude_and_direction(flat_world, vel, wind):
    """F = c |V_app| V_app with V_app = wind - v on every axis; zero wind + climb -> drag down.
    Also checks the force is really applied: a = g + F_drag / m over the first step."""
    v = load_vehicle("x500")
    c = sum(d.coefficient(flat_world.air_density) for d in v.drag.values())
    ws = {"law": {"type": "constant", "velocity_enu": list(wind)}}
    r = run_simulation(flat_world, mission([_air(50.0, velocity_enu=list(vel))], max_duration_s=0.02, wind=ws),
                       OpenLoop(lambda o: [0.0] * 4), seed=5, vehicle=v)
    ts = r.timeseries
    va = np.subtract(wind, vel)
    f_exp = c * np.linalg.norm(va) * va
    f = np.array([ts[f"drag_enu_{a}_n"][0] for a in "xyz"])
    assert np.allclose(f, f_exp, rtol=1e-9, atol=1e-12)
    assert np.allclose([ts[f"air_app_enu_{a}_mps"][0] for a in "xyz"], va)
    if wind == (0.0, 0.0, 0.0) and vel[2] > 0:
        assert f[2] < 0
    acc1 = np.array([ts[f"acc_enu_{a}_mps2"][1] for a in "xyz"])
    assert np.allclose(acc1, np.array([0, 0, -G]) + f_exp / v.dry_mass(), atol=2e-3)


def test_tank_at_rest_weighs_the_liquid(flat_world):
    r = run_simulation(flat_world, mission(max_duration_s=1.0), OpenLoop(lambda o: [0.0] * 4), seed=6)
    ts = r.timeseries
    settled = ts["t_s"] >= 0.2
    assert np.allclose(ts["tank_force_enu_z_n"][settled], -1.0 * G, rtol=0.005)
    assert np.allclose(ts["tank_force_grav_enu_z_n"], -1.0 * G)
    assert abs(ts["tank_force_inertial_enu_z_n"][settled]).max() < 0.05
    assert ts["on_ground"].all()


def test_drain_time_equals_volume_over_flow(flat_world):
    """The pump switched on at t = 0 lags its command by tau_up: it delivers q tau_up less than a step, so the
    tank is empty at V / q + tau_up (exactly, for the first-order lag)."""
    q = 0.05  # L/s -> 1 L in 20 s
    r = run_simulation(flat_world, mission(max_duration_s=25.0, record_rate_hz=50.0),
                       OpenLoop(lambda o: [0.0] * 4, flow_lps=q), seed=7)
    dt = 1.0 / flat_world.physics_rate_hz
    tau = flat_world.vehicle.sprayer.pump.tau_up_s
    assert abs(r.metrics["tank_empty_s"] - (1.0 / q + tau)) <= dt + 1e-9
    assert [e.kind for e in r.events].count("tank_empty") == 1
    level = r.timeseries["tank_level_l"]
    assert level.min() >= 0.0 and level[-1] == 0.0
    assert np.all(np.diff(level) <= 1e-12)
    assert r.timeseries["total_mass_kg"][-1] == pytest.approx(flat_world.vehicle.dry_mass())


def test_tank_empty_event_when_the_flow_stops_at_a_tiny_level(flat_world):
    """The autopilot closes the nozzle once the level reads <= 1e-6 L: a floating-point residue
    (1 L at 0.02 L/s in 4 ms steps) must not leave the tank 'almost empty' without a tank_empty event."""
    q = 0.02
    ap = OpenLoop(lambda o: [0.0] * 4, flow_lps=q)
    step = ap.step

    def step_closing(obs):
        ap.flow = q if obs.tank_level_l > 1e-6 else 0.0
        return step(obs)

    ap.step = step_closing
    r = run_simulation(flat_world, mission(max_duration_s=51.0, record_rate_hz=10.0), ap, seed=7)
    dt = 1.0 / flat_world.physics_rate_hz
    assert [e.kind for e in r.events].count("tank_empty") == 1
    tau = flat_world.vehicle.sprayer.pump.tau_up_s  # the pump's lag (test above)
    assert abs(r.metrics["tank_empty_s"] - (1.0 / q + tau)) <= dt + 1e-9
    assert r.timeseries["tank_level_l"][-1] == 0.0


def test_yaw_torque_sign(flat_world):
    """Speeding up the CCW rotors (1, 2) yaws the body clockwise (negative ENU yaw rate)."""
    v = flat_world.vehicle
    w = v.hover_speed(v.dry_mass() + 1.0, G)
    ccw = [i for i, rr in enumerate(v.rotors) if rr.spin == "ccw"]
    cmd = [w * (1.05 if i in ccw else 0.95) for i in range(4)]
    r = run_simulation(flat_world, mission([_air(10.0, cmd)], max_duration_s=1.0), OpenLoop(lambda o: cmd),
                       seed=8)
    ts = r.timeseries
    assert ts["omega_flu_z_radps"][-1] < -0.1
    assert ts["yaw_rad"][-1] < -0.01
    # and the opposite for the CW rotors
    cmd2 = [w * (0.95 if i in ccw else 1.05) for i in range(4)]
    r2 = run_simulation(flat_world, mission([_air(10.0, cmd2)], max_duration_s=1.0), OpenLoop(lambda o: cmd2),
                        seed=8)
    assert r2.timeseries["omega_flu_z_radps"][-1] > 0.1


def test_overloaded_vehicle_cannot_leave_the_ground(flat_world):
    v = flat_world.vehicle
    payload = v.max_thrust() / G - v.dry_mass() - 1.0 + 0.3  # T/W < 1 at w_max with a full tank
    r = run_simulation(flat_world, mission(max_duration_s=3.0, payload_kg=payload),
                       OpenLoop(lambda o: [v.motor.w_max] * 4), seed=9)
    ts = r.timeseries
    assert v.max_thrust() < r.metrics["total_mass_start_kg"] * G
    assert ts["on_ground"].all()
    assert ts["pos_enu_z_m"].max() - ts["pos_enu_z_m"][0] < 0.01
    assert math.isnan(r.metrics["liftoff_s"])
    # control: the same vehicle without the overload lifts off
    r2 = run_simulation(flat_world, mission(max_duration_s=3.0), OpenLoop(lambda o: [v.motor.w_max] * 4), seed=9)
    assert r2.metrics["liftoff_s"] < 1.0
    assert r2.timeseries["pos_enu_z_m"].max() > 1.0


def test_liftoff_jump_of_tank_force(flat_world):
    """At lift-off the tank force exceeds the weight (inertial part), then settles in a steady climb."""
    v = flat_world.vehicle
    w_h = v.hover_speed(v.dry_mass() + 1.0, G)
    r = run_simulation(flat_world, mission(max_duration_s=3.0), OpenLoop(lambda o: [1.15 * w_h] * 4), seed=10)
    ts = r.timeseries
    t_lo = r.metrics["liftoff_s"]
    assert 0.0 < t_lo < 1.0
    around = (ts["t_s"] > t_lo) & (ts["t_s"] < t_lo + 0.3)
    assert ts["tank_force_enu_z_n"][around].min() < -1.1 * G  # heavier than its weight while accelerating up


def test_same_seed_identical_time_series(flat_world):
    v = flat_world.vehicle
    w = v.hover_speed(v.dry_mass() + 1.0, G)
    wind = {"law": {"type": "dryden", "mean_mps": 3.0, "intensity": "moderate"}}

    def run(seed: int):
        ap = OpenLoop(lambda o: [w * (1 + 0.01 * o.imu.accel_flu[0])] * 4)
        return run_simulation(flat_world, mission([_air(5.0, w)], max_duration_s=2.0, wind=wind), ap, seed=seed)

    a, b, c = run(11), run(11), run(12)
    for k in a.timeseries:
        assert np.array_equal(a.timeseries[k], b.timeseries[k], equal_nan=True), k
    assert not np.array_equal(a.timeseries["wind_enu_x_mps"], c.timeseries["wind_enu_x_mps"])


def test_link_drag_uses_the_link_velocity_with_rotation(flat_world):
    """A drag link 0.5 m ahead of the CoM on a body spinning at ω about z moves at ω × r = (0, 0.5 ω, 0):
    its drag is -c (0.5 ω)² along y, and its torque slows the spin."""
    from vinecli.specs.vehicle import DragLinkSpec

    c, wz = 0.2, 4.0
    x500 = load_vehicle("x500")
    arm = x500.model_copy(update={"drag": {"arm": DragLinkSpec(coefficient_kg_per_m=c, position_m=(0.5, 0.0, 0.0))}})
    phase = _air(50.0, angular_velocity_flu=[0.0, 0.0, wz])
    r = run_simulation(flat_world, mission([phase], max_duration_s=0.5), OpenLoop(lambda o: [0.0] * 4), seed=1,
                       vehicle=arm)
    ts = r.timeseries
    assert ts["drag_enu_y_n"][0] == pytest.approx(-c * (0.5 * wz) ** 2, rel=1e-9)
    assert ts["drag_enu_x_n"][0] == pytest.approx(0.0, abs=1e-12)
    # torque r × F = 0.5 · (-c (0.5 ω)²) about z: dω/dt = τ / I_zz at the start
    izz = arm.frame.inertia_kgm2[2] + 4 * arm.motor.rotor_mass_kg * (0.174**2 * 2 + 0.06**2 / 2)
    dw = (ts["omega_flu_z_radps"][2] - ts["omega_flu_z_radps"][1]) / 0.004
    assert dw == pytest.approx(0.5 * -c * (0.5 * wz) ** 2 / izz, rel=0.05)
    r0 = run_simulation(flat_world, mission([phase], max_duration_s=0.5), OpenLoop(lambda o: [0.0] * 4), seed=1,
                        vehicle=x500.model_copy(update={"drag": {}}))
    assert r0.timeseries["omega_flu_z_radps"][-1] == pytest.approx(wz, rel=1e-6)
    assert ts["omega_flu_z_radps"][-1] < wz - 0.1


def test_recording_rate_and_final_row(flat_world):
    ap = OpenLoop(lambda o: [0.0] * 4, done_after_s=1.23)
    r = run_simulation(flat_world, mission(max_duration_s=5.0, record_rate_hz=10.0), ap, seed=1)
    t = r.timeseries["t_s"]
    assert r.status is RunStatus.COMPLETED and r.sim_time_s == pytest.approx(1.232)
    assert np.allclose(t[:-1], np.arange(13) * 0.1)  # 10 Hz
    assert t[-1] == pytest.approx(1.232)  # the last step is always recorded
    assert r.events[-1].kind == "status" and r.events[-1].data["status"] == "completed"
    r2 = run_simulation(flat_world, mission(max_duration_s=0.5), OpenLoop(lambda o: [0.0] * 4), seed=1,
                        should_stop=lambda: True)
    assert r2.status is RunStatus.INTERRUPTED and r2.sim_time_s == 0.0


def test_liftoff_when_thrust_exceeds_the_weight(flat_world):
    """Ramp the rotors: the lift-off event comes within 0.08 s of thrust = total weight, and while
    accelerating the tank force is m (g + a) with a = (T + D - (M + m) g) / (M + m)."""
    v = flat_world.vehicle
    w_h = v.hover_speed(v.dry_mass() + 1.0, G)
    ap = OpenLoop(lambda o: [w_h * min(1.1, o.t_us * 1e-6 / 2.0 * 1.1)] * 4)
    r = run_simulation(flat_world, mission(max_duration_s=2.5), ap, seed=0)
    ts = r.timeseries
    m_all = v.dry_mass() + 1.0
    t_cross = ts["t_s"][np.argmax(ts["thrust_total_n"] > m_all * G)]
    assert 0.0 <= r.metrics["liftoff_s"] - t_cross < 0.08
    late = ts["t_s"] > 2.1
    a = (ts["thrust_total_n"][late] + ts["drag_enu_z_n"][late] - m_all * G) / m_all
    assert np.allclose(ts["acc_enu_z_mps2"][late], a, atol=0.01)
    assert np.allclose(ts["tank_force_enu_z_n"][late], -1.0 * (G + a), atol=0.02)
