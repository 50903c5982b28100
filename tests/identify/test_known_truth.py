"""Known truth first: a simulated flight of a known vehicle (the real loop: PyBullet, vinecli's physics and
built-in autopilot), written out as the ULog and the DataFlash log a real flight leaves, fits back to the
vehicle's own parameters within the tolerances below (README "Your drone: fit a vehicle to a flight log").

The vehicle is not the base the fit starts from: its thrust constant is 15 % higher than the x500's, its
output mapping starts at 150 rad/s (x500: 100), its body drag area is 1.5 times, the rotor drag 1.5 times,
and its battery is another pack. The mass and w_max are the x500's, so every parameter is comparable.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from tests.flightlog.synthetic_log import cut
from vinecli.cli.app import app
from vinecli.constants import STANDARD_GRAVITY
from vinecli.flightlog.dataflash_write import write_dataflash
from vinecli.flightlog.from_run import flightlog_from_run
from vinecli.flightlog.ulog_write import write_ulog
from vinecli.identify.fit import fit_flight_log
from vinecli.vehicle import load_vehicle

runner = CliRunner()

TRUTH = """\
base: x500
name: truth-quad
description: the known-truth vehicle of the fit round trip
motor: {k_f: 9.8e-6, k_d: 1.2e-4}
px4: {w_min_rad_s: 150.0}
drag: {base: {area_m2: 0.09, cd0: 1.0}}
battery: {cells: 4, capacity_wh: 60.0, internal_resistance_ohm_per_cell: 0.008, motor_efficiency: 0.75,
          avionics_w: 12.0, initial_soc: 0.9}
"""
#: take-off, hold, a loop at 6 m/s climbing and descending between 4 and 10 m, hold, climb, land
PHASES: list[dict[str, Any]] = [
    {"type": "takeoff", "altitude_agl_m": 6.0, "climb_speed_mps": 2.5}, {"type": "hold", "duration_s": 2.0},
    {"type": "waypoints", "waypoints": [[20, 0, 6], [20, 15, 10], [-15, 15, 4], [-15, -10, 8], [0, 0, 6]],
     "speed_mps": 6.0},
    {"type": "hold", "duration_s": 2.0}, {"type": "goto", "position_enu": [0, 0], "altitude_agl_m": 12.0},
    {"type": "land", "descent_speed_mps": 1.5}]
#: relative tolerance of each fitted parameter against the truth (measured: README, BENCHMARKS.md)
TOLERANCE = {"hover_throttle": 0.01, "k_f": 0.05, "thrust_theta_mps2": 0.10, "thrust_curve_offset_r": 0.25,
             "thrust_to_weight": 0.05, "body_drag_kg_per_m": 0.10, "k_d": 0.10, "pack_resistance_ohm": 0.05,
             "capacity_wh": 0.05, "motor_efficiency": 0.05, "hover_power_w": 0.03}


def _truth(v: Any) -> dict[str, float]:
    """The truth vehicle's values of the fitted parameters."""
    m, n, g = v.dry_mass(), v.n_rotors, STANDARD_GRAVITY
    w_min, w_max, k_f = v.px4.w_min_rad_s, v.motor.w_max, v.motor.k_f
    dw = w_max - w_min
    w_h = math.sqrt(m * g / (n * k_f))
    b = v.battery
    return {"hover_throttle": (w_h - w_min) / dw, "k_f": k_f, "thrust_theta_mps2": k_f * dw**2 / m,
            "thrust_curve_offset_r": w_min / dw, "thrust_to_weight": n * k_f * w_max**2 / (m * g),
            "body_drag_kg_per_m": sum(d.coefficient(1.225) for d in v.drag.values()), "k_d": v.motor.k_d,
            "pack_resistance_ohm": b.cells * b.internal_resistance_ohm_per_cell, "capacity_wh": b.capacity_wh,
            "motor_efficiency": b.motor_efficiency,
            "hover_power_w": n * v.motor.k_m * k_f * w_h**3 / b.motor_efficiency + b.avionics_w}


@pytest.fixture(scope="module")
def flight(tmp_path_factory: pytest.TempPathFactory, flat_world_dir: Path) -> dict[str, Any]:
    from vinecli.autopilot.registry import make_autopilot
    from vinecli.sim.runner import run_simulation
    from vinecli.specs.mission import MissionSpec
    from vinecli.world import load_world

    d = tmp_path_factory.mktemp("truth")
    (d / "truth.yaml").write_text(TRUTH)
    mission = MissionSpec(name="truth-flight", vehicle=str(d / "truth.yaml"), max_duration_s=120, record_rate_hz=100,
                          phases=PHASES)
    ap = make_autopilot("builtin")
    try:
        res = run_simulation(load_world(flat_world_dir), mission, ap, seed=3)
    finally:
        ap.close()
    assert res.status.value == "completed", res.detail
    truth = load_vehicle(d / "truth.yaml")
    log = flightlog_from_run(res.timeseries, truth)
    return {"dir": d, "truth": truth, "values": _truth(truth), "ulog": write_ulog(log, d / "truth.ulg"),
            # the DataFlash copy loses 3 s of motor outputs and IMU mid-flight (a logger dropout)
            "bin": write_dataflash(cut(log, 30.0, 33.0), d / "truth.bin")}


def _check_parameters(params: dict[str, Any], truth: dict[str, float]) -> None:
    for name, tol in TOLERANCE.items():
        got = params[name]["value"]
        assert got == pytest.approx(truth[name], rel=tol), f"{name}: fitted {got:.6g}, truth {truth[name]:.6g}"


@pytest.fixture(scope="module")
def ulog_fit(flight: dict[str, Any]) -> Path:
    """``vinecli vehicle fit`` of the simulated ULog: the output directory."""
    out = flight["dir"] / "fit-ulog"
    r = runner.invoke(app, ["vehicle", "fit", str(flight["ulog"]), "--out", str(out), "--base", "x500"])
    assert r.exit_code == 0, r.output
    assert "hover throttle" in r.output and "replay errors" in r.output
    return out


def test_the_ulog_fits_back_to_the_known_vehicle(flight: dict[str, Any], ulog_fit: Path) -> None:
    out = ulog_fit
    rep = json.loads((out / "fit.json").read_text())
    _check_parameters(rep["parameters"], flight["values"])
    assert rep["cells"] == 4
    assert abs(rep["hover_check"]["error_fraction"]) < 0.01
    assert abs(rep["energy"]["error_fraction"]) < 0.02
    assert all(abs(x) < 0.02 for x in rep["energy"]["held_out_error_fractions"])
    assert rep["hover_pwm_us"] == pytest.approx(1000.0 + 1000.0 * rep["hover_throttle"])
    # still air in the simulation: no wind found
    assert rep["parameters"]["wind_east_mps"]["source"] == "none"
    # the replay of the simulated flight through the fitted vehicle: closer than both baselines
    replay = json.loads((out / "replay.json").read_text())
    for key in ("accel_rms_mps2", "velocity_rms_mps", "voltage_rms_v", "energy_error_fraction"):
        assert replay[key] < min(b[key] for b in replay["baselines"].values()), key
    assert replay["accel_rms_mps2"] < 0.3 and replay["energy_error_fraction"] < 0.01
    # the fitted vehicle is a vehicle vinecli flies, with its provenance
    v = load_vehicle(out / "vehicle.yaml")
    assert v.provenance is not None and v.provenance.log == "truth.ulg" and v.provenance.base == "x500"
    assert v.provenance.replay["accel_rms_mps2"] == pytest.approx(replay["accel_rms_mps2"])
    doc = yaml.safe_load((out / "vehicle.yaml").read_text())
    assert doc["base"] == "x500" and "k_f" in doc["motor"]
    html = (out / "fit.html").read_text()
    assert html.count("data:image/png;base64,") >= 4 and "<script" not in html


def test_the_dataflash_log_with_a_gap_fits_back_too(flight: dict[str, Any]) -> None:
    r = fit_flight_log(flight["bin"], base="x500", replay=False)
    _check_parameters(r.report["parameters"], flight["values"])
    (g0, g1), = r.log.gaps
    assert g0 == pytest.approx(29.9, abs=0.05) and g1 == pytest.approx(33.0, abs=0.05)
    assert any(n.startswith("gaps in the log") for n in r.report["notes"])
    s = r.samples
    assert not s.airborne[(s.t_s > 29.9) & (s.t_s < 33.1)].any()  # nothing across the dropout is used


def test_a_run_with_the_fitted_vehicle_carries_its_provenance(flight: dict[str, Any], ulog_fit: Path,
                                                               flat_world_dir: Path) -> None:
    from vinecli.report.loader import load_runs
    from vinecli.report.markdown import render_markdown
    from vinecli.runs import RunRequest, run_mission

    out = ulog_fit
    mission = flight["dir"] / "quick.yaml"
    mission.write_text(yaml.safe_dump({
        "name": "quick-fitted", "vehicle": str(out / "vehicle.yaml"), "max_duration_s": 30, "record_rate_hz": 25,
        "phases": [{"type": "takeoff", "altitude_agl_m": 2.0}, {"type": "hold", "duration_s": 1.0}, {"type": "land"}]}))
    run = run_mission(RunRequest(mission, flat_world_dir, flight["dir"] / "runs", seed=1))
    summary = json.loads((Path(run.run_dir) / "summary.json").read_text())
    assert summary["status"] == "completed"
    fit = summary["vehicle_fit"]
    assert fit["log"] == "truth.ulg" and fit["firmware"] == "vinecli simulation" and fit["base"] == "x500"
    assert set(fit["replay"]) == {"accel_rms_mps2", "velocity_rms_mps", "voltage_rms_v", "energy_error_fraction"}
    assert set(fit["replay_baselines"]) == {"log_mean", "base_unfitted"}
    md = render_markdown(load_runs(flight["dir"] / "runs"))
    assert "Fitted vehicles" in md and "truth.ulg" in md and "replay errors" in md
    assert np.isfinite(fit["replay"]["accel_rms_mps2"])
