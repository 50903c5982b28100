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
from vinecli.identify.fitted_params import Param, block_bootstrap, fixed
from vinecli.identify.samples import FlightSamples

__all__ = ["R_MAX", "SLOW_MPS", "ThrustFit", "fit_thrust"]

SLOW_MPS = 4.0
#: largest curve offset r (idle speed w_min at most 40 % of w_max)
R_MAX = 0.4 / 0.6
#: r counts as identified when its bootstrap std is below this and it is not at a bound
R_STD_MAX = 0.15
MIN_SAMPLES = 20
#: the curve is fitted on block means over this long (the _Blocks docstring says why), s
BLOCK_S = 0.5


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

    @property
    def expo(self) -> Param:
        """The firmware's thrust expo of this curve: ``(u + r)² - r²`` normalised is ``(1 - e) u + e u²`` with
        ``e = 1 / (1 + 2 r)`` exactly (PX4 THR_MDL_FAC, ArduPilot MOT_THST_EXPO describe thrust that way)."""
        r = self.r
        e = 1.0 / (1.0 + 2.0 * r.value)
        std = 2.0 * r.std / (1.0 + 2.0 * r.value) ** 2 if math.isfinite(r.std) else math.nan
        return Param(e, "1", std, "derived" if r.source == "fit" else r.source,
                     "equivalent thrust expo 1 / (1 + 2 r): THR_MDL_FAC / MOT_THST_EXPO of this curve")

    def specific_thrust(self, u: np.ndarray) -> np.ndarray:
        """Body-z specific force (m/s²) of outputs ``u`` (N, n); NaN outputs (stopped) give no thrust."""
        uu = np.asarray(u, dtype=float)
        w = np.where(np.isfinite(uu), uu + self.r.value, 0.0)
        return self.theta.value * np.sum(w * w, axis=1)

    def hover_u_at(self, f_z: np.ndarray) -> np.ndarray:
        """The equal output on every rotor that gives body-z specific force ``f_z`` (m/s²)."""
        return np.sqrt(np.maximum(f_z, 0.0) / (self.n_rotors * self.theta.value)) - self.r.value


class _Blocks:
    """Consecutive used samples averaged over blocks of at most :data:`BLOCK_S`: per block the means of
    ``sum u_i²``, ``sum u_i`` and ``f_z``, so ``mean sum (u_i + r)² = S2 + 2 r S1 + n r²`` for any ``r``.

    A motor output in a log is a snapshot of a command whose fast part (the attitude loop's) the motors'
    lag filters out of the thrust: regressed sample by sample, that noise in the regressor flattens the
    curve (the known-truth flight: r +45 %). Averaging both sides over half a second divides that noise
    and keeps the slow variation (climbs, descents, manoeuvres) the shape is fitted on."""

    def __init__(self, s: FlightSamples, used: np.ndarray, fz: np.ndarray) -> None:
        idx = np.flatnonzero(used)
        groups: list[list[int]] = []
        for i in idx:
            if groups and i == groups[-1][-1] + 1 and s.t_s[i] - s.t_s[groups[-1][0]] < BLOCK_S:
                groups[-1].append(int(i))
            else:
                groups.append([int(i)])
        self.n = s.u.shape[1]
        self.s2 = np.array([np.mean(np.sum(s.u[g] ** 2, axis=1)) for g in groups])
        self.s1 = np.array([np.mean(np.sum(s.u[g], axis=1)) for g in groups])
        self.f = np.array([np.mean(fz[g]) for g in groups])
        self.t = np.array([np.mean(s.t_s[g]) for g in groups])
        self.u_mean = self.s1 / self.n

    def theta(self, r: float, i: np.ndarray | slice = slice(None)) -> tuple[float, float]:
        """Closed-form theta at offset ``r`` and the residual sum of squares (over blocks ``i``)."""
        x = self.s2[i] + 2.0 * r * self.s1[i] + self.n * r * r
        th = float(x @ self.f[i] / (x @ x))
        return th, float(np.sum((self.f[i] - th * x) ** 2))

    def solve(self, r_fixed: float | None, i: np.ndarray | slice = slice(None)) -> np.ndarray:
        """(theta, r): theta in closed form, r by a bounded scalar search of the residual's profile on
        [0, R_MAX]; ``r_fixed``: theta only."""
        if r_fixed is None:
            r_fixed = float(minimize_scalar(lambda r: self.theta(r, i)[1], bounds=(0.0, R_MAX), method="bounded",
                                            options={"xatol": 1e-5}).x)
        return np.array([self.theta(r_fixed, i)[0], r_fixed])


def fit_thrust(s: FlightSamples, r_base: float, *, path: str = "", drag_z: np.ndarray | None = None) -> ThrustFit:
    """Fit the curve on ``s``; ``r_base`` is the base vehicle's ``w_min / (w_max - w_min)``. ``drag_z``: the
    body drag's specific force along body z at each sample (m/s², from a drag fit), taken off the measured
    ``f_z`` first (a climb meets air from above: without it the curve comes out too flat)."""
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
    fz_all = s.f_body[:, 2] - (0.0 if drag_z is None else drag_z)
    b = _Blocks(s, used, fz_all)
    free = b.solve(None)
    std = block_bootstrap(b.t, lambda i: b.solve(None, i))
    at_bound = free[1] < 1e-3 or free[1] > R_MAX - 1e-3
    span = f"outputs {np.percentile(b.u_mean, 5):.2f}-{np.percentile(b.u_mean, 95):.2f}"
    if at_bound or not std[1] < R_STD_MAX:
        why = f"at the edge of 0..{R_MAX:.2f}" if at_bound else f"std {std[1]:.2f}"
        p = b.solve(r_base)
        std = np.array([block_bootstrap(b.t, lambda i: b.solve(r_base, i))[0], math.nan])
        r = fixed(r_base, "1", f"the curve's shape is not identified by this log ({span}, free fit r = {free[1]:.3f}, "
                  f"{why}): w_min / (w_max - w_min) of the base vehicle")
    else:
        p = free
        r = Param(float(p[1]), "1", float(std[1]), "fit", f"w_min / (w_max - w_min), shape over {span}")
    theta = Param(float(p[0]), "m/s^2", float(std[0]), "fit", f"k_f (w_max - w_min)^2 / m from {int(used.sum())} "
                  f"samples below {SLOW_MPS:g} m/s ({len(b.t)} blocks of {BLOCK_S:g} s)")
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
    resid = fz_all[air] - fit.specific_thrust(s.u[air])
    fast = air & (s.speed >= SLOW_MPS)
    fast_res = float(np.mean(fz_all[fast] - fit.specific_thrust(s.u[fast]))) if fast.sum() >= 5 else None
    if fast_res is not None:
        notes.append(f"above {SLOW_MPS:g} m/s the thrust is {fast_res:+.2f} m/s² off the curve on average"
                     + (" after the body drag along z" if drag_z is not None else "")
                     + " (axial inflow: vinecli's rotors have none)")
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
