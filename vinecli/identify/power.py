"""Electrical power against the motor outputs: hover power, figure of merit, the flight's energy.

vinecli's load (``flight.battery.ElectricalLoad.power_w``): ``P = sum_i k_m k_f w_i³ / eta + P_avionics``
(shaft power ``k_m T w`` over the motor+ESC efficiency). With ``w_i = (w_max - w_min)(u_i + r)`` that is
``P = a sum_i (u_i + r)³ + P0``: linear in ``a`` and ``P0`` at the thrust curve's ``r``, regressed on the
log's ``V I`` (terminal power) at each battery sample against the outputs averaged over that sample's
interval (stopped motors: 0, so disarmed samples pin ``P0``). ``a`` fixes ``k_m / eta`` only: the
efficiency is fitted with ``k_m`` kept from the base (``k_m`` is also the rotors' yaw torque, which a
10 Hz log cannot see), unless that puts it outside :data:`ETA_RANGE`; then ``eta`` stays the base's and
``k_m`` takes the fit. Ideal hover power ``(m g)^1.5 / sqrt(2 rho n A)`` (momentum theory) uses the mass
and propeller of the base: their product with the fitted hover power is the overall figure of merit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from vinecli.flightlog.flight_log import BatteryLog
from vinecli.identify.battery_fit import energy_wh
from vinecli.identify.fitted_params import Param, block_bootstrap, fixed
from vinecli.identify.samples import FlightSamples, interval_means
from vinecli.identify.thrust import ThrustFit

__all__ = ["ETA_RANGE", "PowerFit", "fit_power", "model_power_w"]

ETA_RANGE = (0.5, 0.95)


@dataclass(frozen=True)
class PowerFit:
    """``P = a sum (u + r)³ + P0`` (module docstring), the hover power and the energy check."""

    a_w: Param
    avionics_w: Param
    hover_power_w: Param
    rms_w: float
    samples: int
    energy: dict[str, Any] = field(default_factory=dict)


def cube_sum(u: np.ndarray, running: np.ndarray, r: float) -> np.ndarray:
    """``sum_i (u_i + r)³`` per sample, 0 where the motors are stopped."""
    w = np.where(np.isfinite(u), u + r, 0.0)
    return np.where(running, np.sum(w**3, axis=1), 0.0)


def model_power_w(s: FlightSamples, fit: PowerFit, r: float) -> np.ndarray:
    """The model's electrical power at each motor-output sample, W."""
    return fit.a_w.value * cube_sum(s.u, s.running, r) + fit.avionics_w.value


def _regressor(s: FlightSamples, b: BatteryLog, r: float) -> np.ndarray:
    """Mean of ``sum (u + r)³`` over each battery sample's interval (its neighbours' half-way points)."""
    x = cube_sum(s.u, s.running, r)[:, None]
    h = 0.5 * float(np.median(np.diff(b.t_s))) if len(b.t_s) > 1 else 0.5
    h = max(h, 0.6 * float(np.median(np.diff(s.t_s))))
    m, _ = interval_means(s.t_s, x, b.t_s, h)
    return m[:, 0]


def _lsq(x: np.ndarray, p: np.ndarray, p0: float | None = None) -> np.ndarray:
    """(a, P0) by least squares; ``p0`` given: a only."""
    if p0 is not None:
        return np.array([float(x @ (p - p0) / (x @ x)), p0])
    a = np.column_stack([x, np.ones_like(x)])
    return np.linalg.lstsq(a, p, rcond=None)[0]


def fit_power(s: FlightSamples, b: BatteryLog, thrust: ThrustFit, span: tuple[float, float],
              base_avionics_w: float) -> PowerFit:
    """Fit on the battery samples within ``span`` (s, the usable flight) and check the energy there. A log
    whose motors never stop cannot tell the avionics from the motors' power at idle: a negative ``P0`` is
    replaced by the base vehicle's avionics power and ``a`` refitted."""
    r = thrust.r.value
    x = _regressor(s, b, r)
    p = b.voltage_v * b.current_a
    ok = np.isfinite(x) & np.isfinite(p) & (b.t_s >= span[0]) & (b.t_s <= span[1])
    x, p, t = x[ok], p[ok], b.t_s[ok]
    coef = _lsq(x, p)
    p0: float | None = None
    if coef[1] < 0.0:
        p0 = base_avionics_w
        coef = _lsq(x, p, p0)
    std = block_bootstrap(t, lambda i: _lsq(x[i], p[i], p0), block_s=10.0)
    stopped = int(np.sum(x == 0.0))
    av = (Param(float(coef[1]), "W", float(std[1]), "fit", f"power with the motors stopped ({stopped} samples)")
          if p0 is None else fixed(p0, "W", "the motors never stop in this flight and the free fit gives a negative "
                                   "avionics power: base vehicle's"))
    n = thrust.n_rotors
    uh = thrust.hover_throttle.value
    ph = coef[0] * n * (uh + r) ** 3 + coef[1]
    ph_std = math.hypot(std[0] * n * (uh + r) ** 3, 0.0 if p0 is not None else std[1])
    fit = PowerFit(
        a_w=Param(float(coef[0]), "W", float(std[0]), "fit", f"power per unit sum (u + r)^3, {len(p)} battery samples"),
        avionics_w=av,
        hover_power_w=Param(float(ph), "W", ph_std, "derived", "electrical power at the hover throttle"),
        rms_w=float(np.sqrt(np.mean((p - (coef[0] * x + coef[1])) ** 2))), samples=len(p))
    return replace(fit, energy=_energy_check(s, b, fit, r, span, x, p, t))


def _energy_check(s: FlightSamples, b: BatteryLog, fit: PowerFit, r: float, span: tuple[float, float],
                  x: np.ndarray, p: np.ndarray, t: np.ndarray) -> dict[str, Any]:
    """The flight's energy from the log (V I) and from the model (outputs), over ``span``; and held out: the
    model fitted on one half of the flight predicting the other."""
    def log_e(t0: float, t1: float) -> float:
        m = (b.t_s >= t0) & (b.t_s <= t1)
        return energy_wh(b.t_s[m], (b.voltage_v * b.current_a)[m])

    def model_e(coef: np.ndarray, t0: float, t1: float) -> float:
        m = (s.t_s >= t0) & (s.t_s <= t1)
        return energy_wh(s.t_s[m], coef[0] * cube_sum(s.u[m], s.running[m], r) + coef[1])

    t0, t1 = span
    e_log = log_e(t0, t1)
    e_mod = model_e(np.array([fit.a_w.value, fit.avionics_w.value]), t0, t1)
    mid = 0.5 * (t0 + t1)
    held = []
    for (a0, a1), (b0, b1) in (((t0, mid), (mid, t1)), ((mid, t1), (t0, mid))):
        m = (t >= a0) & (t <= a1)
        if m.sum() >= 3:
            coef = _lsq(x[m], p[m], None if fit.avionics_w.source == "fit" else fit.avionics_w.value)
            e = log_e(b0, b1)
            held.append((model_e(coef, b0, b1) - e) / e if e > 0 else math.nan)
    return {"span_s": [t0, t1], "log_wh": e_log, "model_wh": e_mod,
            "error_fraction": (e_mod - e_log) / e_log if e_log > 0 else None,
            "held_out_error_fractions": held,
            "note": "log: integral of V I over the battery samples; model: integral of the fitted power of the motor "
                    "outputs; held out: fitted on one half of the flight, predicting the other"}
