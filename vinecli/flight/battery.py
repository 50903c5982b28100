"""Lithium-polymer battery and the vehicle's electrical load (plain Python, no PyBullet).

Model (one equivalent cell times ``cells`` in series, SI units):

* state of charge ``soc`` = remaining energy / ``capacity_wh`` (energy-based, 0..1);
* open-circuit voltage per cell ``E_c(soc)``: Chen & Rincón-Mora (2006), IEEE Trans. Energy
  Conversion 21(2) 504-511, eq. for a Li-polymer cell,
  ``-1.031 e^(-35 soc) + 3.685 + 0.2156 soc - 0.1178 soc² + 0.3201 soc³`` (4.10 V full, 3.80 V at
  half, the knee below ~10 %), or a table from the spec;
* terminal voltage ``V = E - I R`` with ``E = cells E_c`` and ``R = cells r_cell``; a load power
  ``P = V I`` needs ``I = 2 P / (E + sqrt(E² - 4 R P))``; above the pack's maximum power
  ``E² / (4 R)`` the pack delivers that maximum and ``saturated`` is set (brown-out);
* the chemical energy drawn, ``E I dt`` (= load + ``I² R`` heat), lowers ``soc``: so the integral of
  ``power_drawn_w`` over a run equals ``capacity_wh (soc_0 - soc_end)`` by construction.

Electrical load (:class:`ElectricalLoad`): shaft power of the rotors (``k_m T w`` summed,
:class:`~vinecli.flight.motor.MotorBank`) over the motor+ESC efficiency, plus avionics, plus the
pump in proportion to the flow (``pump_w_at_max_flow`` at the nozzles' maximum flow).
"""

from __future__ import annotations

import math
from typing import final

from vinecli.specs.vehicle import BatterySpec

__all__ = ["Battery", "ElectricalLoad", "ocv_chen_rincon_mora"]


def ocv_chen_rincon_mora(soc: float) -> float:
    """Open-circuit voltage of one Li-polymer cell, V, at state of charge ``soc`` (0..1)."""
    s = min(max(soc, 0.0), 1.0)
    return -1.031 * math.exp(-35.0 * s) + 3.685 + s * (0.2156 + s * (-0.1178 + s * 0.3201))


@final
class ElectricalLoad:
    """What the pack must deliver (module doc). ``max_flow_lps``: the nozzles' maximum flow, L/s (None: no
    tank, no pump)."""

    def __init__(self, spec: BatterySpec, max_flow_lps: float | None) -> None:
        self.inv_efficiency = 1.0 / spec.motor_efficiency
        self.avionics_w = float(spec.avionics_w)
        self.pump_w_per_lps = spec.pump_w_at_max_flow / max_flow_lps if max_flow_lps is not None else 0.0

    def pump_w(self, flow_lps: float) -> float:
        """Electrical power of the pump at ``flow_lps`` L/s, W (linear in the flow)."""
        return self.pump_w_per_lps * flow_lps

    def power_w(self, shaft_power_w: float, flow_lps: float) -> float:
        """Load power, W: ``shaft / efficiency + avionics + pump(flow)``."""
        return shaft_power_w * self.inv_efficiency + self.avionics_w + self.pump_w(flow_lps)


class Battery:
    """One pack: ``update(load_w, dt)`` advances it; read ``soc``, ``voltage_v``, ``current_a``.

    After an update, ``soc_start`` is the state of charge at the start of that interval and
    ``voltage_v``/``current_a``/``power_drawn_w`` hold over it (what a time-series row at the
    interval's start shows).
    """

    def __init__(self, spec: BatterySpec, soc: float | None = None) -> None:
        self.spec = spec
        self.cells = spec.cells
        self.r_ohm = spec.cells * spec.internal_resistance_ohm_per_cell
        self.capacity_j = spec.capacity_wh * 3600.0
        self._table = spec.ocv_table
        self.reset(spec.initial_soc if soc is None else soc)

    def reset(self, soc: float) -> None:
        """A fresh (or swapped) pack at ``soc``, no load."""
        self.soc = min(max(float(soc), 0.0), 1.0)
        self.soc_start = self.soc
        self.current_a = 0.0
        self.load_w = 0.0
        self.power_drawn_w = 0.0
        self.saturated = False
        self.voltage_v = self.open_circuit_v()

    def ocv_cell(self, soc: float) -> float:
        """Open-circuit voltage of one cell at ``soc``, V."""
        t = self._table
        if t is None:
            return ocv_chen_rincon_mora(soc)
        if soc <= t[0][0]:
            return t[0][1]
        for (s0, v0), (s1, v1) in zip(t, t[1:], strict=False):
            if soc <= s1:
                return v0 + (v1 - v0) * (soc - s0) / (s1 - s0)
        return t[-1][1]

    def open_circuit_v(self) -> float:
        """Pack open-circuit voltage now, V."""
        return self.cells * self.ocv_cell(self.soc)

    def max_power_w(self) -> float:
        """Largest load power the pack can deliver now, W (infinite without resistance)."""
        e = self.open_circuit_v()
        return math.inf if self.r_ohm <= 0.0 else e * e / (4.0 * self.r_ohm)

    def update(self, load_w: float, dt: float) -> None:
        """Deliver ``load_w`` W for ``dt`` s (held constant): current, sagged voltage, energy drawn."""
        e = self.open_circuit_v()
        p = load_w if load_w > 0.0 else 0.0
        r = self.r_ohm
        p_max = e * e / (4.0 * r) if r > 0.0 else math.inf
        self.saturated = p > p_max
        if self.saturated:
            p = p_max
        i = 2.0 * p / (e + math.sqrt(max(e * e - 4.0 * r * p, 0.0))) if e > 0.0 else 0.0
        self.current_a = i
        self.load_w = p
        self.voltage_v = e - i * r
        self.power_drawn_w = e * i
        self.soc_start = self.soc
        soc = self.soc - e * i * dt / self.capacity_j
        self.soc = soc if soc > 0.0 else 0.0

    @property
    def depleted(self) -> bool:
        """No energy left."""
        return self.soc <= 0.0
