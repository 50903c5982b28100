"""Drag per unit mass from the in-plane specific force: body drag, rotor drag and the day's steady wind.

With a steady horizontal wind ``w`` the apparent air is ``w - v`` and vinecli's laws give, along body x
and y (FLU), ``f_x = b_x + (c / m) |V| V_x + (k_d / m) (sum_i w_i) V_x`` with ``V = R^T (w - v)`` (and the
same for y): the body's quadratic drag ``c |V| V`` (``flight.aero.wind_drag``, ``c`` = the sum over the
vehicle's drag links) and the rotors' H-force ``k_d w V_perp`` (``flight.motor``), with
``w_i = (w_max - w_min)(u_i + r)`` from the thrust curve. ``b_x, b_y`` absorb the accelerometer's
offsets and a thrust axis not quite along the IMU's z (a tilted mount reads a steady in-plane force).

Linear least squares in ``(b_x, b_y, c/m, k_d/m)`` with ``c, k_d >= 0``; the wind by a variable-projection
least squares around it (a flight with legs in several directions at speed separates wind from drag;
a wind smaller than twice its std is dropped). Stds by block bootstrap. A coefficient the flight cannot
separate (a slow flight cannot tell a quadratic drag from a linear one) is fixed from the base vehicle
and the rest refitted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from vinecli.frames import quat_rotate_many
from vinecli.identify.fitted_params import Param, block_bootstrap, fixed
from vinecli.identify.samples import FlightSamples
from vinecli.identify.thrust import ThrustFit

__all__ = ["DragFit", "air_body", "fit_drag"]

#: bootstrap resamples of the wind (each one a small nonlinear fit)
WIND_RESAMPLES = 40


@dataclass(frozen=True)
class DragFit:
    """``c_per_mass`` (1/m), ``kd_per_mass`` (k_d (w_max - w_min) / m, 1/s per unit of sum(u + r)), offsets, wind."""

    c_per_mass: Param
    kd_per_mass: Param
    bias_x: Param
    bias_y: Param
    wind_e: Param
    wind_n: Param
    rms_mps2: float
    rms_still_air_mps2: float
    max_speed_mps: float
    samples: int

    @property
    def wind(self) -> tuple[float, float]:
        """Steady horizontal wind (east, north), m/s."""
        return (self.wind_e.value, self.wind_n.value)

    def body_drag_z(self, s: FlightSamples) -> np.ndarray:
        """The body drag's specific force along body z at the samples in the fitted wind, m/s²."""
        v = air_body(s, self.wind)
        return self.c_per_mass.value * np.linalg.norm(v, axis=1) * v[:, 2]

    def specific_force_xy(self, s: FlightSamples, r: float) -> np.ndarray:
        """Model in-plane specific force (N, 2) at the samples ``s`` in the fitted wind, m/s² body FLU."""
        v = air_body(s, self.wind)
        sp = np.linalg.norm(v, axis=1)
        w = np.sum(np.where(np.isfinite(s.u), s.u + r, 0.0), axis=1)
        k = self.c_per_mass.value * sp + self.kd_per_mass.value * w
        return np.column_stack([self.bias_x.value + k * v[:, 0], self.bias_y.value + k * v[:, 1]])


def air_body(s: FlightSamples, wind: tuple[float, float], mask: np.ndarray | None = None) -> np.ndarray:
    """Apparent air ``R^T (w - v)`` (N, 3) m/s in body FLU at the samples (``mask``: a subset)."""
    m = slice(None) if mask is None else mask
    q_inv = s.quat[m] * np.array([-1.0, -1.0, -1.0, 1.0])
    return quat_rotate_many(q_inv, np.array([wind[0], wind[1], 0.0]) - s.vel_enu[m])


def _design(va: np.ndarray, u: np.ndarray, f: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """Stacked x and y equations: columns (b_x, b_y, c/m, kd/m), targets f_x, f_y."""
    sp = np.linalg.norm(va, axis=1)
    w = np.sum(u + r, axis=1)
    n = len(va)
    one, zero = np.ones(n), np.zeros(n)
    ax = np.column_stack([one, zero, sp * va[:, 0], w * va[:, 0]])
    ay = np.column_stack([zero, one, sp * va[:, 1], w * va[:, 1]])
    return np.vstack([ax, ay]), np.concatenate([f[:, 0], f[:, 1]])


def _solve(a: np.ndarray, b: np.ndarray, fix: dict[int, float]) -> np.ndarray:
    """Least squares with the columns in ``fix`` held at their values and the drag columns (2, 3) >= 0:
    a negative one is held at 0 and the rest refitted (an active set; two columns at most)."""
    fix = dict(fix)
    while True:
        free = [j for j in range(a.shape[1]) if j not in fix]
        rhs = b - sum((a[:, j] * v for j, v in fix.items()), np.zeros_like(b))
        af = a[:, free]
        x = np.linalg.solve(af.T @ af, af.T @ rhs)  # normal equations: 2-4 columns, solved thousands of times
        neg = [j for j, v in zip(free, x, strict=True) if j >= 2 and v < 0.0]
        if not neg:
            break
        fix[neg[0]] = 0.0
    out = np.empty(a.shape[1])
    out[free] = x
    for j, v in fix.items():
        out[j] = v
    return out


class _Problem:
    """The airborne samples' arrays; ``residual(wind, idx)`` after the inner linear solve. The apparent air
    ``R^T (w - v)`` is linear in the wind: ``w_e R^T e + w_n R^T n - R^T v``, each term computed once."""

    def __init__(self, s: FlightSamples, mask: np.ndarray, r: float) -> None:
        self.u, self.f, self.r = s.u[mask], s.f_body[mask], r
        q_inv = s.quat[mask] * np.array([-1.0, -1.0, -1.0, 1.0])
        self.east = quat_rotate_many(q_inv, np.array([1.0, 0.0, 0.0]))
        self.north = quat_rotate_many(q_inv, np.array([0.0, 1.0, 0.0]))
        self.v_body = quat_rotate_many(q_inv, s.vel_enu[mask])
        self.n = int(mask.sum())

    def system(self, wind: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        i = slice(None) if idx is None else idx
        va = wind[0] * self.east[i] + wind[1] * self.north[i] - self.v_body[i]
        return _design(va, self.u[i], self.f[i], self.r)

    def residual(self, wind: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        a, b = self.system(wind, idx)
        return b - a @ _solve(a, b, {})

    def wind(self, idx: np.ndarray | None = None, w0: np.ndarray | None = None) -> np.ndarray:
        start = np.zeros(2) if w0 is None else w0
        return np.asarray(least_squares(lambda w: self.residual(w, idx), start, x_scale=1.0, diff_step=1e-3).x)


def fit_drag(s: FlightSamples, thrust: ThrustFit, base_c_per_mass: float, base_kd_per_mass: float, *,
             wind_std: bool = True) -> DragFit:
    """Fit (module docstring); ``base_*`` are the base vehicle's values per unit mass, used when not identified.
    ``wind_std=False`` skips the wind's bootstrap (a first pass: the wind is then kept as fitted)."""
    mask = s.airborne
    prob = _Problem(s, mask, thrust.r.value)
    t = s.t_s[mask]
    n = prob.n
    w = prob.wind()
    w_std = (block_bootstrap(t, lambda i: prob.wind(i, w), resamples=WIND_RESAMPLES) if wind_std
             else np.zeros(2))
    rms_still = float(np.sqrt(np.mean(prob.residual(np.zeros(2)) ** 2)))
    significant = bool(np.hypot(*w) > 2.0 * np.hypot(*w_std))
    if not significant:
        w = np.zeros(2)
    a, b = prob.system(w)

    def run(fix: dict[int, float]) -> tuple[np.ndarray, np.ndarray]:
        def one(i: np.ndarray) -> np.ndarray:
            rows = np.concatenate([i, i + n])
            return _solve(a[rows], b[rows], fix)
        return _solve(a, b, fix), block_bootstrap(t, one)

    x, std = run({})
    fix: dict[int, float] = {}
    base = {2: base_c_per_mass, 3: base_kd_per_mass}
    for j in (3, 2):
        if not (x[j] > 0.0 and std[j] < 0.5 * x[j]):
            fix[j] = base[j]
    if fix and len(fix) < 2:  # one coefficient fixed: the other refitted alone (and kept only if identified then)
        x, std = run(fix)
        j = 5 - next(iter(fix))
        if not (x[j] > 0.0 and std[j] < 0.5 * x[j]):
            fix[j] = base[j]
    if fix:
        x, std = run(fix)
    vmax = float(np.max(s.speed[mask])) if n else 0.0
    names = {2: ("1/m", "body drag c / m"), 3: ("1/s", "rotor drag k_d (w_max - w_min) / m")}
    params: dict[int, Param] = {}
    for j, (unit, what) in names.items():
        if j in fix:
            params[j] = fixed(x[j], unit, f"{what}: not separable in this flight (up to {vmax:.1f} m/s): base vehicle's")
        else:
            params[j] = Param(float(x[j]), unit, float(std[j]), "fit", f"{what}, {n} airborne samples up to {vmax:.1f} m/s")
    wind_note = ("steady wind of the flight (the replay flies in still air)" if significant else
                 f"no steady wind beyond twice its std ({np.hypot(*w_std):.1f} m/s): still air assumed")
    resid = b - a @ x
    return DragFit(c_per_mass=params[2], kd_per_mass=params[3],
                   bias_x=Param(float(x[0]), "m/s^2", float(std[0]), "fit", "in-plane offset along body x"),
                   bias_y=Param(float(x[1]), "m/s^2", float(std[1]), "fit", "in-plane offset along body y"),
                   wind_e=Param(float(w[0]), "m/s", float(w_std[0]), "fit" if significant else "none", wind_note),
                   wind_n=Param(float(w[1]), "m/s", float(w_std[1]), "fit" if significant else "none", wind_note),
                   rms_mps2=float(math.sqrt(np.mean(resid**2))) if len(resid) else math.nan,
                   rms_still_air_mps2=rms_still, max_speed_mps=vmax, samples=n)
