"""The pack: cells, open-circuit voltage at the start, internal resistance, capacity.

vinecli's battery (``flight.battery``): terminal ``V = E(soc) - I R``, ``E = cells E_cell(soc)`` (Chen &
Rincón-Mora's Li-polymer curve, or the base's ``ocv_table``), ``soc`` the energy fraction. Over one flight
the open-circuit voltage falls almost linearly with the charge drawn ``q = integral I dt`` (Ah), so
``V = E0 - k q - R I`` is a linear regression: ``R`` comes from the current steps (take-off, climbs),
``E0`` is the rest voltage at the start and gives the start's state of charge on the curve, and the slope
``k`` gives the capacity through the curve's slope there: ``capacity_wh = cells E_cell'(soc0) E0 / k``.
A short flight draws a few percent of the pack, so ``k`` (and the capacity) is often not identified:
then the capacity comes from the log's parameter (BAT1_CAPACITY, BATT_CAPACITY, mAh x 3.7 V per cell)
or the base vehicle. Cells: the log's parameter, else the rest voltage (3.3-4.35 V per cell).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vinecli.flight.battery import Battery
from vinecli.flightlog.arrays import cells_from_voltage
from vinecli.flightlog.flight_log import BatteryLog, LogConfig
from vinecli.identify.fitted_params import Param, block_bootstrap, fixed
from vinecli.specs.vehicle import BatterySpec

__all__ = ["BatteryFit", "charge_ah", "energy_wh", "fit_battery", "soc_at_ocv"]

#: nominal LiPo cell voltage turning a mAh rating into Wh
NOMINAL_CELL_V = 3.7


@dataclass(frozen=True)
class BatteryFit:
    """Fitted pack (module docstring); ``soc_start`` on the base's open-circuit curve."""

    cells: Param
    ocv_start_v: Param
    soc_start: Param
    resistance_ohm: Param
    ocv_slope_v_per_ah: Param
    capacity_wh: Param
    rms_v: float
    samples: int
    current_logged: bool


def charge_ah(b: BatteryLog) -> np.ndarray:
    """Charge drawn since the first sample, Ah (trapezoid over the samples; missing currents count 0)."""
    i = np.nan_to_num(b.current_a)
    dq = 0.5 * (i[1:] + i[:-1]) * np.diff(b.t_s) / 3600.0
    return np.concatenate(([0.0], np.cumsum(dq)))


def energy_wh(t: np.ndarray, p: np.ndarray) -> float:
    """Integral of power ``p`` (W) over times ``t`` (s), Wh (trapezoid)."""
    return float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t)) / 3600.0) if len(t) > 1 else 0.0


def soc_at_ocv(cell: Battery, v_cell: float) -> float:
    """State of charge where ``cell``'s open-circuit curve gives ``v_cell`` V (bisection; the curve rises
    with soc; clamped to 0..1)."""
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if cell.ocv_cell(mid) < v_cell else (lo, mid)
    return 0.5 * (lo + hi)


def fit_battery(b: BatteryLog, config: LogConfig, base: BatterySpec) -> BatteryFit:
    """Fit the pack on the log's battery stream (module docstring)."""
    cell_curve = Battery(base)
    has_i = bool(np.isfinite(b.current_a).sum() >= 5)
    q = charge_ah(b)
    ok = np.isfinite(b.voltage_v) & (np.isfinite(b.current_a) if has_i else True)
    if has_i:
        a = np.column_stack([np.ones(ok.sum()), -q[ok], -b.current_a[ok]])
    else:
        a = np.ones((int(ok.sum()), 1))
    y = b.voltage_v[ok]
    x = np.linalg.lstsq(a, y, rcond=None)[0]
    std = block_bootstrap(b.t_s[ok], lambda i: np.linalg.lstsq(a[i], y[i], rcond=None)[0], block_s=10.0)
    e0 = float(x[0])
    rms = float(np.sqrt(np.mean((y - a @ x) ** 2)))
    if config.cells:
        cells = Param(float(config.cells), "1", 0.0, "log", "cells in series from the log's parameters")
    else:
        n = cells_from_voltage(e0)
        cells = (Param(float(n), "1", 0.0, "fit", f"from the rest voltage {e0:.2f} V ({e0 / n:.2f} V per cell)")
                 if n else fixed(base.cells, "1", f"rest voltage {e0:.2f} V fits no LiPo cell count: base vehicle's"))
    nc = cells.value
    soc0 = soc_at_ocv(cell_curve, e0 / nc)
    slope = _curve_slope(cell_curve, soc0, soc0)
    soc_std = std[0] / max(nc * slope, 1e-6)
    if has_i and x[2] > 0.0:
        r = Param(float(x[2]), "ohm", float(std[2]), "fit", f"pack resistance from {int(ok.sum())} samples, "
                  f"currents {np.nanmin(b.current_a):.1f}-{np.nanmax(b.current_a):.1f} A")
    else:
        why = "no current in the log" if not has_i else f"the fit gives {x[2]:.3f} ohm"
        r = fixed(nc * base.internal_resistance_ohm_per_cell, "ohm", f"{why}: the base's resistance per cell")
    if has_i:
        k = Param(float(x[1]), "V/Ah", float(std[1]), "fit", f"open-circuit fall over {q[-1] * 1000:.0f} mAh drawn")
    else:
        k = fixed(math.nan, "V/Ah", "no current in the log", source="none")
    cap = _capacity(config, nc, k, cell_curve, soc0, float(q[-1]), e0, base)
    return BatteryFit(cells=cells, ocv_start_v=Param(e0, "V", float(std[0]), "fit", "open-circuit voltage at the start"),
                      soc_start=Param(soc0, "1", soc_std, "derived", "state of charge on the base's open-circuit curve"),
                      resistance_ohm=r, ocv_slope_v_per_ah=k, capacity_wh=cap, rms_v=rms, samples=int(ok.sum()),
                      current_logged=has_i)


def _curve_slope(cell: Battery, soc_a: float, soc_b: float) -> float:
    """Slope of the open-circuit curve (V per unit of charge) between two states of charge (the secant; at a
    point when they are equal)."""
    lo, hi = min(soc_a, soc_b), max(soc_a, soc_b)
    if hi - lo < 2e-3:
        lo, hi = max(lo - 1e-3, 0.0), min(hi + 1e-3, 1.0)
    return (cell.ocv_cell(hi) - cell.ocv_cell(lo)) / (hi - lo)


def _capacity(config: LogConfig, cells: float, k: Param, cell: Battery, soc0: float, q_ah: float, e0: float,
              base: BatterySpec) -> Param:
    """From the log's parameter, else from the open-circuit slope when identified, else the base's. The
    slope ``k`` is the curve's mean slope over the charge the flight drew: its secant between the start's
    state of charge and the end's (found from the capacity, so twice round)."""
    from_slope = None
    if k.source == "fit" and k.value > 0.0:
        slope = _curve_slope(cell, soc0, soc0)
        for _ in range(3):
            c = cells * slope * e0 / k.value
            slope = _curve_slope(cell, soc0, max(soc0 - q_ah * e0 / c, 0.0))
        c = cells * slope * e0 / k.value
        c_std = c * k.std / k.value
        from_slope = Param(c, "Wh", c_std, "fit", f"from the open-circuit slope {k.value:.3f} V/Ah and the curve's "
                           f"mean slope {slope:.3f} V per unit of charge over the flight")
    if config.capacity_mah:
        wh = config.capacity_mah / 1000.0 * NOMINAL_CELL_V * cells
        check = f"; the voltage's slope says {from_slope.value:.0f} ± {from_slope.std:.0f} Wh" if from_slope else ""
        return Param(wh, "Wh", math.nan, "log", f"{config.capacity_mah:g} mAh x {NOMINAL_CELL_V} V x {cells:g} cells{check}")
    if from_slope is not None and from_slope.identified:
        return from_slope
    why = f"the flight draws too little to see it ({from_slope.value:.0f} ± {from_slope.std:.0f} Wh)" if from_slope else \
        "not identified"
    return fixed(base.capacity_wh, "Wh", f"capacity {why}: base vehicle's")
