"""The thrust curve: motor output -> thrust per unit mass, and the hover throttle.

vinecli's rotors make ``T_i = k_f w_i²`` and a firmware output ``u`` in [0, 1] commands
``w = w_min + u (w_max - w_min)`` (``px4.w_min_rad_s``, ``motor.w_max``; Gazebo's mapping). So the
specific force along the body z axis is ``f_z = theta * sum_i (u_i + r)²`` with
``theta = k_f (w_max - w_min)² / m`` and ``r = w_min / (w_max - w_min)``: a log identifies the curve per
unit mass, never the mass. Fitted by least squares on the airborne samples slower than
:data:`SLOW_MPS` (faster, the rotors meet axial inflow that vinecli's rotor model leaves out, and the
body's drag acts along z: both bend the curve). ``r`` sets the curve's shape (PX4's THR_MDL_FAC /
ArduPilot's MOT_THST_EXPO describe the same thing in the firmware); it is identified only when the
outputs span a wide enough range, otherwise it is fixed from the base vehicle and only ``theta`` is fitted.
Hover throttle ``u_h = sqrt(g / (n theta)) - r`` (thrust = weight, level).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from vinecli.constants import STANDARD_GRAVITY
from vinecli.errors import InputError
from vinecli.identify.params import Param, block_bootstrap, fixed
from vinecli.identify.samples import FlightSamples

__all__ = ["R_MAX", "SLOW_MPS", "ThrustFit", "fit_thrust"]

SLOW_MPS = 4.0
#: largest curve offset r (idle speed w_min at most 40 % of w_max)
R_MAX = 0.4 / 0.6
#: r counts as identified when its bootstrap std is below this and it is not at a bound
R_STD_MAX = 0.15
MIN_SAMPLES = 20


@dataclass(frozen=True)
class ThrustFit:
    """The fitted curve (module docstring), its quality and the samples it used."""

    n_rotors: int
    theta: Param
    r: Param
    hover_throttle: Param
    thrust_to_weight: Param
    used: np.ndarray  # mask into the samples
    rms_mps2: float
    fast_residual_mps2: float | None  # mean f_z residual above SLOW_MPS (None: no fast samples)
    hover_check: dict[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def specific_thrust(self, u: np.ndarray) -> np.ndarray:
        """Body-z specific force (m/s²) of outputs ``u`` (N, n); NaN outputs (stopped) give no thrust."""
        uu = np.asarray(u, dtype=float)
        w = np.where(np.isfinite(uu), uu + self.r.value, 0.0)
        return self.theta.value * np.sum(w * w, axis=1)

    def hover_u_at(self, f_z: np.ndarray) -> np.ndarray:
        """The equal output on every rotor that gives body-z specific force ``f_z`` (m/s²)."""
        return np.sqrt(np.maximum(f_z, 0.0) / (self.n_rotors * self.theta.value)) - self.r.value


def _theta(u: np.ndarray, fz: np.ndarray, r: float) -> tuple[float, float]:
    """Closed-form theta at offset ``r`` and the residual sum of squares."""
    s = np.sum((u + r) ** 2, axis=1)
    th = float(s @ fz / (s @ s))
    return th, float(np.sum((fz - th * s) ** 2))


def _solve(u: np.ndarray, fz: np.ndarray, r_fixed: float | None) -> np.ndarray:
    """(theta, r) by least squares: theta in closed form, r by a bounded scalar search on [0, R_MAX]
    (the profile of the residual); ``r_fixed``: theta only."""
    if r_fixed is None:
        r_fixed = float(minimize_scalar(lambda r: _theta(u, fz, r)[1], bounds=(0.0, R_MAX), method="bounded",
                                        options={"xatol": 1e-5}).x)
    return np.array([_theta(u, fz, r_fixed)[0], r_fixed])


def fit_thrust(s: FlightSamples, r_base: float, *, path: str = "") -> ThrustFit:
    """Fit the curve on ``s``; ``r_base`` is the base vehicle's ``w_min / (w_max - w_min)``."""
    n_rot = s.u.shape[1]
    air = s.airborne
    if air.sum() < MIN_SAMPLES:
        raise InputError(f"only {int(air.sum())} usable airborne samples (need {MIN_SAMPLES}): nothing to fit the "
                         "thrust on (no flight, or the vehicle never left the ground)", path=path or None)
    notes = []
    used = air & (s.speed < SLOW_MPS)
    if used.sum() < MIN_SAMPLES:
        used = air
        notes.append(f"fewer than {MIN_SAMPLES} samples below {SLOW_MPS:g} m/s: the curve uses every airborne sample")
    u, fz, t = s.u[used], s.f_body[used, 2], s.t_s[used]
    free = _solve(u, fz, None)
    std = block_bootstrap(t, lambda i: _solve(u[i], fz[i], None))
    at_bound = free[1] < 1e-3 or free[1] > R_MAX - 1e-3
    u_mean = u.mean(axis=1)
    span = f"outputs {np.percentile(u_mean, 5):.2f}-{np.percentile(u_mean, 95):.2f}"
    if at_bound or not std[1] < R_STD_MAX:
        why = f"at the edge of 0..{R_MAX:.2f}" if at_bound else f"std {std[1]:.2f}"
        p = _solve(u, fz, r_base)
        std = np.array([block_bootstrap(t, lambda i: _solve(u[i], fz[i], r_base))[0], math.nan])
        r = fixed(r_base, "1", f"the curve's shape is not identified by this log ({span}, free fit r = {free[1]:.3f}, "
                  f"{why}): w_min / (w_max - w_min) of the base vehicle")
    else:
        p = free
        r = Param(float(p[1]), "1", float(std[1]), "fit", f"w_min / (w_max - w_min), shape over {span}")
    theta = Param(float(p[0]), "m/s^2", float(std[0]), "fit",
                  f"k_f (w_max - w_min)^2 / m from {len(fz)} samples below {SLOW_MPS:g} m/s")
    g = STANDARD_GRAVITY
    uh = math.sqrt(g / (n_rot * p[0])) - p[1]
    d_theta = 0.5 * math.sqrt(g / n_rot) * p[0] ** -1.5 * std[0]
    uh_std = math.hypot(d_theta, 0.0 if math.isnan(std[1]) else std[1])
    tw = n_rot * p[0] * (1.0 + p[1]) ** 2 / g
    tw_std = tw * math.hypot(std[0] / p[0], 0.0 if math.isnan(std[1]) else 2.0 * std[1] / (1.0 + p[1]))
    fit = ThrustFit(
        n_rotors=n_rot, theta=theta, r=r,
        hover_throttle=Param(uh, "1", uh_std, "derived", "output giving thrust = weight, level"),
        thrust_to_weight=Param(tw, "1", tw_std, "derived", "thrust at full output / weight"),
        used=used, rms_mps2=0.0, fast_residual_mps2=None, notes=tuple(notes))
    resid = s.f_body[air, 2] - fit.specific_thrust(s.u[air])
    fast = air & (s.speed >= SLOW_MPS)
    fast_res = float(np.mean(s.f_body[fast, 2] - fit.specific_thrust(s.u[fast]))) if fast.sum() >= 5 else None
    if fast_res is not None:
        notes.append(f"above {SLOW_MPS:g} m/s the measured body-z specific force is {fast_res:+.2f} m/s² off the "
                     "curve on average (axial inflow and body drag along z)")
    return replace(fit, rms_mps2=float(np.sqrt(np.mean(resid**2))), fast_residual_mps2=fast_res,
                   hover_check=_hover_check(s, fit), notes=tuple(notes))


def _hover_check(s: FlightSamples, fit: ThrustFit) -> dict[str, Any]:
    """The hover throttle against the log's own steady-hover outputs (HOVER_LIMITS samples)."""
    hov = s.hover()
    if hov.sum() < 3:
        return {"samples": int(hov.sum()), "note": "no steady hover in the log"}
    log_u = float(np.mean(s.u[hov]))
    at_f = float(np.mean(fit.hover_u_at(s.f_body[hov, 2])))
    uh = fit.hover_throttle.value
    return {"samples": int(hov.sum()), "log_hover_output": log_u, "hover_throttle": uh,
            "error_fraction": (uh - log_u) / log_u,
            "measured_specific_force_mps2": float(np.mean(s.f_body[hov, 2])),
            "output_at_measured_specific_force": at_f, "error_fraction_at_measured_specific_force": (at_f - log_u) / log_u}
