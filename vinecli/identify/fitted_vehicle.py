"""The fitted curves in vinecli's vehicle parameters, and the ``vehicle.yaml`` that flies them.

A log measures forces per unit mass, so every force parameter scales with the mass (``--mass``, else the
base vehicle's) and the rotor speeds with the base's ``w_max`` (a log has no RPM):
``w_max - w_min = w_max / (1 + r)``, ``w_min = r (w_max - w_min)``, ``k_f = theta m / (w_max - w_min)²``,
``k_d = kd_per_mass m / (w_max - w_min)``, ``c = c_per_mass m`` (the base's drag links scaled to it).
Power: ``a = k_m k_f (w_max - w_min)³ / eta``; the efficiency is fitted with the base's ``k_m`` unless it
falls outside :data:`~vinecli.identify.power.ETA_RANGE` (then ``k_m`` moves, ``eta`` stays the base's).
The momentum-theory figure of merit ``sqrt(k_f) / (k_m sqrt(2 rho A))`` (README) and the overall one,
ideal hover power over the fitted motor power, follow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from vinecli.constants import STANDARD_GRAVITY
from vinecli.identify.base_vehicle import BaseVehicle
from vinecli.identify.battery_fit import BatteryFit
from vinecli.identify.drag import DragFit
from vinecli.identify.fitted_params import Param, fixed
from vinecli.identify.power import ETA_RANGE, PowerFit
from vinecli.identify.replay_model import AIR_DENSITY
from vinecli.identify.thrust import ThrustFit
from vinecli.specs.vehicle import VehicleSpec

__all__ = ["ALWAYS_FROM_BASE", "FittedVehicle", "fitted_vehicle"]

#: what no flight log identifies, with the reason (always from --base)
ALWAYS_FROM_BASE = {
    "motor.w_max": "rotor speeds: a log has no RPM; the curve is fitted in outputs, the speeds scale with w_max",
    "motor.tau_up_s, motor.tau_down_s": "motor lag: 5-10 Hz motor outputs cannot resolve a 10-50 ms time constant",
    "frame.inertia_kgm2": "rate dynamics: the attitude controller's corrections at 250-400 Hz are not in a 10 Hz log",
    "motor.k_roll": "rolling moment: a torque, only visible through the rate dynamics",
    "rotors": "geometry and spin: from the frame, not from a log",
    "motor.prop_diameter_m": "disk area: enters the ideal hover power only",
    "sensors, control, tank, sprayer": "not what a flight log measures",
}


@dataclass(frozen=True)
class FittedVehicle:
    """Parameters (vinecli's names and units, each with std and source) and the YAML overrides of the base."""

    params: dict[str, Param]
    overrides: dict[str, Any]
    fixed_from_base: list[str]
    notes: list[str]


def _scaled(p: Param, value: float, unit: str, what: str) -> Param:
    """``value`` with ``p``'s relative std and source (a fitted curve turned into a vinecli parameter)."""
    rel = p.std / p.value if p.value and math.isfinite(p.std) else math.nan
    return Param(value, unit, abs(value * rel) if math.isfinite(rel) else math.nan,
                 "derived" if p.source == "fit" else p.source, what)


def _drag_links(base: VehicleSpec, c_total: float) -> dict[str, Any]:
    """The base's drag links scaled so their coefficients sum to ``c_total`` (kg/m at AIR_DENSITY)."""
    cs = {k: d.coefficient(AIR_DENSITY) for k, d in base.drag.items()}
    total = sum(cs.values())
    if total <= 0.0:
        return {"base": {"coefficient_kg_per_m": c_total}}
    out: dict[str, Any] = {}
    for k, d in base.drag.items():
        if d.coefficient_kg_per_m is not None:
            out[k] = {"coefficient_kg_per_m": cs[k] * c_total / total}
        else:
            out[k] = {"area_m2": d.area_m2, "cd0": float(d.cd0 or 0.0) * c_total / total}
    return out


def fitted_vehicle(base_vehicle: BaseVehicle, mass: Param, thrust: ThrustFit, drag: DragFit, battery: BatteryFit | None,
                   power: PowerFit | None, *, name: str, description: str) -> FittedVehicle:
    """Turn the fits into vinecli parameters and the overrides of the base vehicle (module docstring)."""
    base, base_ref = base_vehicle.spec, base_vehicle.ref
    m, n = mass.value, thrust.n_rotors
    r = thrust.r.value
    w_max = float(base.motor.w_max)
    dw = w_max / (1.0 + r)
    w_min = r * dw
    k_f = _scaled(thrust.theta, thrust.theta.value * m / dw**2, "N/(rad/s)^2", "thrust constant")
    c = _scaled(drag.c_per_mass, drag.c_per_mass.value * m, "kg/m", "body drag, sum over the drag links")
    k_d = _scaled(drag.kd_per_mass, drag.kd_per_mass.value * m / dw, "N/(rad/s)/(m/s)", "rotor drag")
    p: dict[str, Param] = {
        "mass_kg": mass, "k_f": k_f, "w_min_rad_s": _scaled(thrust.r, w_min, "rad/s", "rotor speed at output 0"),
        "body_drag_kg_per_m": c, "k_d": k_d,
    }
    over: dict[str, Any] = {"base": base_ref, "name": name, "description": description,
                            "motor": {"k_f": k_f.value, "k_d": k_d.value, "w_min_armed": w_min},
                            "px4": {"w_min_rad_s": w_min}, "drag": _drag_links(base, c.value)}
    if mass.source != "base":
        over["frame"] = {"mass_kg": m - base.n_rotors * base.motor.rotor_mass_kg - base.payload.mass_kg}
    notes: list[str] = []
    if battery is not None:
        over["battery"] = _battery_block(battery, power, base, k_f.value, dw, p, notes, over)
    fixed_from_base = [f"{k} ({why})" for k, why in ALWAYS_FROM_BASE.items()]
    if mass.source == "base":
        fixed_from_base.insert(0, "frame.mass_kg (a log measures forces per unit mass; pass --mass)")
    fits = {"thrust curve shape r": thrust.r, "body drag": drag.c_per_mass, "rotor drag": drag.kd_per_mass}
    if battery is not None:
        fits.update({"battery capacity": battery.capacity_wh, "battery resistance": battery.resistance_ohm})
    if power is not None:
        fits["avionics power"] = power.avionics_w
    fixed_from_base += [f"{k} ({v.note})" for k, v in fits.items() if v.source == "base"]
    if battery is None:
        fixed_from_base.append("battery and power (no battery voltage in the log)")
    elif power is None:
        fixed_from_base.append("battery.motor_efficiency, battery.avionics_w (no battery current in the log: no power fit)")
    if power is not None and battery is not None:
        _figure_of_merit(base, m, n, power, p, notes)
    return FittedVehicle(params=p, overrides=over, fixed_from_base=fixed_from_base, notes=notes)


def _battery_block(bf: BatteryFit, pw: PowerFit | None, base: VehicleSpec, k_f: float, dw: float,
                   p: dict[str, Param], notes: list[str], over: dict[str, Any]) -> dict[str, Any]:
    """The ``battery:`` overrides (and ``motor.k_m`` when the efficiency cannot carry the power fit)."""
    cells = int(round(bf.cells.value))
    block: dict[str, Any] = {"cells": cells, "capacity_wh": bf.capacity_wh.value,
                             "internal_resistance_ohm_per_cell": bf.resistance_ohm.value / cells}
    p["cells"], p["capacity_wh"] = bf.cells, bf.capacity_wh
    p["internal_resistance_ohm_per_cell"] = _scaled(bf.resistance_ohm, bf.resistance_ohm.value / cells, "ohm",
                                                    "internal resistance per cell")
    if pw is None:
        return block
    eta_base = base.battery.motor_efficiency if base.battery is not None else 0.8
    k_m = float(base.motor.k_m)
    eta = k_m * k_f * dw**3 / pw.a_w.value
    if ETA_RANGE[0] <= eta <= ETA_RANGE[1]:
        p["motor_efficiency"] = _scaled(pw.a_w, eta, "1", "motor + ESC efficiency (with the base's k_m)")
        p["k_m"] = fixed(k_m, "m", "reaction torque / thrust: base vehicle's (the power fixes k_m / efficiency)")
        block["motor_efficiency"] = eta
    else:
        k_m_fit = eta_base * pw.a_w.value / (k_f * dw**3)
        notes.append(f"with the base's k_m the power fit needs a motor efficiency of {eta:.2f} (outside "
                     f"{ETA_RANGE[0]:g}-{ETA_RANGE[1]:g}): the efficiency stays the base's {eta_base:.2f} and k_m "
                     f"becomes {k_m_fit:.4f} m")
        p["motor_efficiency"] = fixed(eta_base, "1", "base vehicle's (the power fit moved k_m instead)")
        p["k_m"] = _scaled(pw.a_w, k_m_fit, "m", "reaction torque / thrust, from the power at the base's efficiency")
        over["motor"]["k_m"] = k_m_fit
        block["motor_efficiency"] = eta_base
    block["avionics_w"] = pw.avionics_w.value
    p["avionics_w"] = pw.avionics_w
    p["hover_power_w"] = pw.hover_power_w
    return block


def _figure_of_merit(base: VehicleSpec, m: float, n: int, pw: PowerFit, p: dict[str, Param], notes: list[str]) -> None:
    """Momentum-theory figure of merit of the fitted rotors and the overall (electrical) one at hover."""
    area = base.motor.disk_area_m2()
    fm = math.sqrt(p["k_f"].value) / (p["k_m"].value * math.sqrt(2.0 * AIR_DENSITY * area))
    p["figure_of_merit"] = Param(fm, "1", math.nan, "derived", "sqrt(k_f) / (k_m sqrt(2 rho A)), base propeller")
    ideal = (m * STANDARD_GRAVITY) ** 1.5 / math.sqrt(2.0 * AIR_DENSITY * n * area)
    motor_w = pw.hover_power_w.value - pw.avionics_w.value
    overall = ideal / motor_w if motor_w > 0 else math.nan
    p["ideal_hover_power_w"] = Param(ideal, "W", math.nan, "derived", "(m g)^1.5 / sqrt(2 rho n A), base mass and prop")
    p["overall_figure_of_merit"] = Param(overall, "1", math.nan, "derived",
                                         "ideal hover power / electrical motor power at hover (FM x efficiency)")
    if math.isfinite(overall) and not 0.3 <= overall <= 0.7:
        implied = (0.5 * motor_w * math.sqrt(2.0 * AIR_DENSITY * n * area)) ** (2.0 / 3.0) / STANDARD_GRAVITY
        notes.append(f"at {m:.2f} kg the measured hover power gives an overall figure of merit of {overall:.2f}, "
                     f"outside the 0.3-0.7 of small multirotors: the vehicle is probably about {implied:.1f} kg "
                     "(0.5); pass --mass if you know it")
