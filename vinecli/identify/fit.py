"""``vinecli vehicle fit``: a flight log -> the vehicle that flew it (what the log identifies, the rest from a base).

:func:`fit_flight_log` computes (read, resample, fit the thrust curve, drag, pack and power, turn them into
vinecli's parameters, replay the log through the result); :func:`fit_vehicle` also writes the output
directory: ``vehicle.yaml`` (``base:`` the base vehicle, the fitted overrides, ``provenance``),
``fit.json`` (every parameter as ``{value, unit, std, source, note}``, ``hover_throttle``,
``hover_pwm_us``, ``cells``, residuals, the energy and hover checks, what was fixed from the base and
why, the replay's errors), ``replay.json`` and ``fit.html`` with its figures.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from vinecli import __version__
from vinecli.errors import InputError
from vinecli.flightlog.read import read_flight_log
from vinecli.identify.base_vehicle import BaseVehicle, fitted_spec, load_base
from vinecli.identify.battery_fit import fit_battery
from vinecli.identify.drag import fit_drag
from vinecli.identify.fit_result import FitResult
from vinecli.identify.fitted_params import Param
from vinecli.identify.fitted_vehicle import fitted_vehicle
from vinecli.identify.power import fit_power
from vinecli.identify.replay import replay_log
from vinecli.identify.replay_model import AIR_DENSITY
from vinecli.identify.samples import make_samples
from vinecli.identify.thrust import fit_thrust
from vinecli.identify.vehicle_io import replay_summary, write_outputs
from vinecli.names import name_from

__all__ = ["FitResult", "fit_flight_log", "fit_vehicle"]

Stage = Callable[[str], None]


def _mass(base: BaseVehicle, mass_kg: float | None) -> Param:
    if mass_kg is not None:
        if not (math.isfinite(mass_kg) and 0.05 <= mass_kg <= 500.0):
            raise InputError(f"--mass {mass_kg} kg is not a multicopter's mass (0.05-500 kg)")
        return Param(float(mass_kg), "kg", math.nan, "user", "take-off mass given with --mass")
    return Param(base.spec.dry_mass(), "kg", math.nan, "base", "the base vehicle's dry mass (not in a log)")


def fit_flight_log(log_path: str | Path, *, base: str = "x500", mass_kg: float | None = None,
                   name: str | None = None, replay: bool = True, stage: Stage | None = None) -> FitResult:
    """Fit the vehicle of ``log_path`` (module docstring); ``stage`` is told each step's name."""
    say = stage or (lambda _s: None)
    say("reading the log")
    log = read_flight_log(log_path)
    b = load_base(base)
    if b.spec.n_rotors != log.config.n_motors:
        raise InputError(f"the log flies {log.config.n_motors} motors, the base vehicle {b.ref!r} has "
                         f"{b.spec.n_rotors} rotors: pass a --base with {log.config.n_motors}", path=log.info.path)
    mass = _mass(b, mass_kg)
    s = make_samples(log)
    say("thrust curve")
    motor, px4 = b.spec.motor, b.spec.px4
    r_base = px4.w_min_rad_s / (motor.w_max - px4.w_min_rad_s)
    c_base = sum(d.coefficient(AIR_DENSITY) for d in b.spec.drag.values()) / mass.value
    thrust = fit_thrust(s, r_base, path=log.info.path)
    say("drag")
    # the curve, the drag, then the curve again without the body drag along z, and the drag on that curve
    drag = fit_drag(s, thrust, c_base, motor.k_d * motor.w_max / (1.0 + thrust.r.value) / mass.value, wind_std=False)
    thrust = fit_thrust(s, r_base, path=log.info.path, drag_z=drag.body_drag_z(s))
    drag = fit_drag(s, thrust, c_base, motor.k_d * motor.w_max / (1.0 + thrust.r.value) / mass.value)
    battery = power = None
    if log.battery is not None and b.spec.battery is not None:
        say("battery and power")
        battery = fit_battery(log.battery, log.config, b.spec.battery)
        if battery.current_logged:
            power = fit_power(s, log.battery, thrust, s.span(), b.spec.battery.avionics_w)
    stem = name_from(Path(log_path).stem, "log")
    vname = name or f"{stem}-fit"
    desc = f"fitted to {Path(log_path).name} ({log.info.firmware}{', ' + log.info.date_utc[:10] if log.info.date_utc else ''})"
    fv = fitted_vehicle(b, mass, thrust, drag, battery, power, name=vname, description=desc)
    prov = {"log": Path(log_path).name, "log_sha256": log.info.sha256, "format": log.info.format,
            "firmware": log.info.firmware, "hardware": log.info.hardware, "flight_date_utc": log.info.date_utc,
            "fitted_utc": datetime.now(UTC).isoformat(timespec="seconds"), "vinecli_version": __version__,
            "base": b.ref, "mass_source": f"{mass.value:.3f} kg, {mass.note}", "fixed_from_base": fv.fixed_from_base}
    yaml_doc = {**fv.overrides, "provenance": prov}
    rep = None
    if replay:
        say("replaying the log")
        spec = fitted_spec(b, yaml_doc, log.info.path)
        rep = replay_log(log, spec, b.spec)
        yaml_doc["provenance"] = {**prov, **replay_summary(rep)}
    result = FitResult(log, s, b, thrust, drag, battery, power, fv, yaml_doc, rep, {})
    return replace(result, report=fit_report(result))


def fit_report(r: FitResult) -> dict[str, Any]:
    """``fit.json``'s content (module docstring)."""
    th, cfg = r.thrust, r.log.config
    params: dict[str, Param] = {"thrust_theta_mps2": th.theta, "thrust_curve_offset_r": th.r,
                                "hover_throttle": th.hover_throttle, "thrust_to_weight": th.thrust_to_weight,
                                "thrust_expo_equivalent": th.expo,
                                "body_drag_per_mass": r.drag.c_per_mass, "rotor_drag_per_mass": r.drag.kd_per_mass,
                                "imu_offset_x_mps2": r.drag.bias_x, "imu_offset_y_mps2": r.drag.bias_y,
                                "wind_east_mps": r.drag.wind_e, "wind_north_mps": r.drag.wind_n}
    if r.battery is not None:
        params.update({"ocv_start_v": r.battery.ocv_start_v, "soc_start": r.battery.soc_start,
                       "pack_resistance_ohm": r.battery.resistance_ohm, "ocv_slope_v_per_ah": r.battery.ocv_slope_v_per_ah})
    if r.power is not None:
        params["power_coefficient_w"] = r.power.a_w
    params.update(r.vehicle.params)
    uh = th.hover_throttle.value
    out: dict[str, Any] = {
        "schema": "vinecli.fit/1", "log": r.log.summary(), "base": r.base.ref,
        "parameters": {k: v.to_dict() for k, v in params.items()},
        "hover_throttle": uh, "hover_throttle_std": th.hover_throttle.std,
        "hover_pwm_us": cfg.pwm_min_us + uh * (cfg.pwm_max_us - cfg.pwm_min_us),
        "cells": int(r.battery.cells.value) if r.battery is not None else None,
        "hover_check": th.hover_check,
        "firmware_hover": {"value": cfg.hover_throttle, "source": cfg.hover_throttle_source},
        "firmware_thrust_expo": {"value": cfg.thrust_expo, "source": cfg.thrust_expo_source},
        "energy": r.power.energy if r.power is not None else None,
        "residuals": {"thrust_rms_mps2": th.rms_mps2, "thrust_fast_flight_mean_mps2": th.fast_residual_mps2,
                      "drag_rms_mps2": r.drag.rms_mps2, "drag_rms_still_air_mps2": r.drag.rms_still_air_mps2,
                      "battery_rms_v": r.battery.rms_v if r.battery else None,
                      "power_rms_w": r.power.rms_w if r.power else None},
        "data": {"motor_samples": len(r.samples.t_s), "airborne_samples": int(r.samples.airborne.sum()),
                 "thrust_samples": int(th.used.sum()), "drag_samples": r.drag.samples,
                 "max_speed_mps": r.drag.max_speed_mps, "battery_samples": r.battery.samples if r.battery else 0,
                 "power_samples": r.power.samples if r.power else 0},
        "fixed_from_base": r.vehicle.fixed_from_base,
        "notes": [*r.samples.notes, *th.notes, *r.vehicle.notes, *cfg.notes],
    }
    if cfg.thrust_expo is not None and th.r.source == "fit":
        e = th.expo
        out["notes"].append(f"the firmware models thrust with {cfg.thrust_expo_source} = {cfg.thrust_expo:g}; this "
                            f"log's curve is {e.value:.2f} ± {e.std:.2f} in the same terms")
    if r.replay is not None:
        out["replay"] = replay_summary(r.replay)
    return out


def fit_vehicle(log_path: str | Path, out: str | Path, *, base: str = "x500", mass_kg: float | None = None,
                name: str | None = None, overwrite: bool = False, stage: Stage | None = None) -> FitResult:
    """Fit and write ``out`` atomically (module docstring): the one call of ``vinecli vehicle fit``."""
    from vinecli.outputs import check_output_target

    check_output_target(Path(out), overwrite=overwrite, inputs=[log_path], kind="vehicle fit")
    result = fit_flight_log(log_path, base=base, mass_kg=mass_kg, name=name, stage=stage)
    if stage:
        stage("writing")
    write_outputs(result, Path(out), overwrite=overwrite, log_path=Path(log_path))
    return result
