"""Spray pump and valve: commanded flow -> delivered flow (plain floats, per physics step).

The input is clean and independent of who computes it: a commanded flow in L/s
(:meth:`Pump.update`), or a duty in [0, 1] of the maximum flow (:meth:`Pump.update_duty`, what a
flight controller's pump PWM output means, e.g. ArduPilot's SERVOn_FUNCTION 22). The delivered
flow follows the command, clamped to ``[0, max_flow]``, through a first-order lag with the time
constant ``tau_up`` while rising (pump spin-up, line pressure) and ``tau_down`` while falling (the
valve closing), discretised exactly: ``q_k = q_c + (q_{k-1} - q_c) e^(-dt/τ)`` (the coefficients are
computed once per step size); the tank drains the exact interval mean
``q_c + (q_{k-1} - q_c) (τ/dt) (1 - e^(-dt/τ))``, so what leaves the nozzles is what the lag
delivers. A first-order lag delivers ``q_c τ`` litres less than a step when
switched on and ``q_c τ`` more when switched off, so a section switched ``v τ`` metres early starts
and ends its deposit where it should (:mod:`vinecli.control.sprayer`).

Nozzle pressure and drop size of the delivered flow: :meth:`vinecli.specs.sprayer.SprayerSpec.pressure_bar`
(q ∝ √p) and :meth:`~vinecli.specs.sprayer.SprayerSpec.vmd_um`.
"""

from __future__ import annotations

import math

from vinecli.specs.sprayer import PumpSpec

__all__ = ["Pump"]


class Pump:
    """Delivered flow (L/s) of the pump and valve; ``max_flow_lps`` from the vehicle (tank ``nozzle_max_flow_lps``)."""

    def __init__(self, spec: PumpSpec, max_flow_lps: float) -> None:
        self.tau_up = float(spec.tau_up_s)
        self.tau_down = float(spec.tau_down_s)
        self.max_flow_lps = float(max_flow_lps)
        #: delivered flow at the end of the last update, L/s
        self.flow_lps = 0.0
        #: mean delivered flow over the last update's step, L/s (what the tank drains)
        self.flow_mean_lps = 0.0
        #: the last command after clamping, L/s
        self.flow_cmd_lps = 0.0
        self._dt = -1.0
        self._keep_up = 0.0  # e^(-dt/tau_up)
        self._keep_down = 0.0  # e^(-dt/tau_down)
        self._mean_up = 0.0  # (tau_up/dt) (1 - e^(-dt/tau_up))
        self._mean_down = 0.0

    def reset(self) -> None:
        """Pump stopped, no flow."""
        self.flow_lps = 0.0
        self.flow_mean_lps = 0.0
        self.flow_cmd_lps = 0.0

    def _coefficients(self, dt: float) -> None:
        self._dt = dt
        self._keep_up = math.exp(-dt / self.tau_up) if self.tau_up > 0.0 else 0.0
        self._keep_down = math.exp(-dt / self.tau_down) if self.tau_down > 0.0 else 0.0
        self._mean_up = self.tau_up / dt * (1.0 - self._keep_up) if dt > 0.0 else 1.0
        self._mean_down = self.tau_down / dt * (1.0 - self._keep_down) if dt > 0.0 else 1.0

    def update(self, flow_cmd_lps: float, dt: float) -> float:
        """Advance ``dt`` s with the commanded flow (L/s); returns the mean delivered flow over the step, L/s
        (``flow_lps`` holds the flow at its end)."""
        if dt != self._dt:
            self._coefficients(dt)
        qc = flow_cmd_lps
        if qc < 0.0 or qc != qc:  # negative or NaN: off
            qc = 0.0
        elif qc > self.max_flow_lps:
            qc = self.max_flow_lps
        self.flow_cmd_lps = qc
        q0 = self.flow_lps
        if qc > q0:
            keep, mean = self._keep_up, self._mean_up
        else:
            keep, mean = self._keep_down, self._mean_down
        q = qc + (q0 - qc) * keep
        qm = qc + (q0 - qc) * mean
        if q < 1e-9 * self.max_flow_lps:  # the exponential tail of a closed valve: no flow
            q = 0.0
            if qc <= 0.0 and q0 <= 0.0:
                qm = 0.0
        self.flow_lps = q
        self.flow_mean_lps = qm
        return qm

    def update_duty(self, duty: float, dt: float) -> float:
        """Advance ``dt`` s at a pump duty in [0, 1] (flow command = duty x maximum flow); mean delivered flow, L/s."""
        d = 0.0 if duty != duty else (0.0 if duty < 0.0 else (1.0 if duty > 1.0 else duty))
        return self.update(d * self.max_flow_lps, dt)
