"""Step timing of the loop: recorded rotor speeds are the speeds at the row's time and
follow the analytic first-order lag; the integration scheme's error bound; open-loop schedules.

Integration scheme (PyBullet, one step per physics tick): semi-implicit (symplectic) Euler with
the forces held constant over the step, ``v_{k+1} = v_k + a_k dt``, ``x_{k+1} = x_k + v_{k+1} dt``.
Under a constant acceleration ``a`` the position after ``t = k dt`` is ``x0 + v0 t + ½ a t (t + dt)``:
it leads the exact solution by ``½ |a| t dt`` = ``|Δv| dt / 2`` (bounded by ``|v| dt / 2`` from rest);
velocities are exact for a constant force.
"""

from __future__ import annotations

import numpy as np
import pytest
from sim_helpers import OpenLoop, mission

from vinecli.autopilot.builtin import BuiltinAutopilot
from vinecli.errors import SpecError
from vinecli.sim.runner import run_simulation
from vinecli.specs import load_spec
from vinecli.specs.mission import MissionSpec
from vinecli.vehicle import load_vehicle

G = 9.80665


def _air(z: float, **phase: object) -> dict[str, object]:
    return {"type": "open_loop", "initial_state": {"position_enu": [0.0, 0.0, z]}, **phase}


def test_recorded_rotor_speed_is_the_analytic_lag_at_the_row_time(flat_world):
    """A speed step at t = 0.1 s: every recorded speed (the last row included) is
    c + (w0 - c) e^(-(t - 0.1)/tau_up) within 0.1 % (the old order showed the next step's speed: 18 % off)."""
    v = flat_world.vehicle
    w0 = v.hover_speed(v.dry_mass() + v.liquid_mass(v.tank.capacity_l), G)
    c = w0 + 80.0
    ph = _air(20.0, duration_s=0.4, schedule=[[0.0, w0], [0.1, c]])
    r = run_simulation(flat_world, mission([ph], max_duration_s=0.4), BuiltinAutopilot(), seed=1)
    ts = r.timeseries
    t, w = ts["t_s"], ts["rotor1_w_radps"]
    tau = v.motor.tau_up_s
    expect = np.where(t < 0.1 - 1e-9, w0, c + (w0 - c) * np.exp(-(t - 0.1) / tau))
    assert np.all(np.abs(w - expect) / expect < 1e-3), np.max(np.abs(w - expect) / expect)
    assert t[-1] == pytest.approx(r.sim_time_s)
    assert w[-1] == pytest.approx(expect[-1], rel=1e-3)


def test_free_fall_error_within_the_documented_bound(flat_world):
    """Semi-implicit Euler: the drop leads ½ g t² by exactly ½ g t dt, never more (module docstring)."""
    x500 = load_vehicle("x500").model_copy(update={"drag": {}})
    r = run_simulation(flat_world, mission([_air(80.0, duration_s=3.0, rotor_speeds_rad_s=0.0)], max_duration_s=3.0),
                       OpenLoop(lambda o: [0.0] * 4), seed=3, vehicle=x500)
    ts = r.timeseries
    t, z, vz = ts["t_s"], ts["pos_enu_z_m"], ts["vel_enu_z_mps"]
    dt = 1.0 / flat_world.physics_rate_hz
    err = (z[0] - z) - 0.5 * G * t**2
    assert np.all(err >= -1e-9)
    assert np.all(err <= 0.5 * G * t * dt + 1e-6)
    assert np.allclose(vz, -G * t, atol=1e-6)  # velocities exact under a constant force


def test_schedule_starting_late_holds_the_previous_command(flat_world):
    """A second open-loop phase whose first breakpoint is at 0.2 s keeps the first phase's speeds
    until then (it used to drop the rotors to 0)."""
    v = flat_world.vehicle
    w0 = v.hover_speed(v.dry_mass() + v.liquid_mass(v.tank.capacity_l), G)
    phases = [_air(20.0, duration_s=0.3, rotor_speeds_rad_s=w0),
              {"type": "open_loop", "duration_s": 0.5, "schedule": [[0.2, w0 + 50.0]]}]
    r = run_simulation(flat_world, mission(phases, max_duration_s=0.8), BuiltinAutopilot(), seed=1)
    ts = r.timeseries
    t, cmd = ts["t_s"], ts["rotor1_cmd_radps"]
    gap = (t > 0.3 + 1e-9) & (t < 0.5 - 1e-9)
    assert gap.any() and np.allclose(cmd[gap], w0)
    assert np.allclose(cmd[(t > 0.5 + 1e-9) & (t < 0.79)], w0 + 50.0)
    assert ts["pos_enu_z_m"].min() > flat_world.spawn_enu[2] + 19.0  # it never fell


def test_initial_state_on_a_later_phase_is_refused():
    d = {"name": "t", "phases": [
        {"type": "takeoff", "altitude_agl_m": 2.0},
        {"type": "open_loop", "duration_s": 1.0, "rotor_speeds_rad_s": 500.0,
         "initial_state": {"position_enu": [0.0, 0.0, 3.0]}}]}
    with pytest.raises(ValueError, match="initial_state is only allowed on the first phase"):
        MissionSpec.model_validate(d)


def test_initial_state_on_a_later_phase_is_a_spec_error_at_load(tmp_path):
    import yaml

    p = tmp_path / "m.yaml"
    p.write_text(yaml.safe_dump({"name": "t", "phases": [
        {"type": "hold", "duration_s": 1.0},
        {"type": "open_loop", "duration_s": 1.0, "rotor_speeds_rad_s": 0.0, "initial_state": {}}]}))
    with pytest.raises(SpecError, match="first phase"):
        load_spec(p, MissionSpec)

