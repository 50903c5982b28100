"""Wind laws (:mod:`vinecli.specs.wind`) turned into a cheap callable field, world ENU, m/s.

``make_wind(spec, seed).velocity(t, p_enu)`` is queried every physics step. Laws:

* ``constant``: the given ENU vector;
* ``sinusoid`` (thesis §5.3): ``W = mean + amplitude sin(2π (t - start)/period + phase)``
  along the horizontal heading for t ≥ start, zero before (start 0 gives the thesis formula);
* ``gust``: 1-cosine ``peak/2 (1 - cos(2π (t - start)/duration))`` for start ≤ t ≤ start +
  duration, horizontal along the heading plus ``vertical_mps`` scaled the same way;
* ``dryden``: mean wind along the heading plus MIL-F-8785C turbulence
  (:mod:`vinecli.flight.dryden`), u along the heading, v to its left, w up; W20 from the
  intensity, else ``mean_mps``; ``sigma_mps`` overrides the horizontal σ (σ_w keeps the
  MIL ratio); filters step at ``dt`` (the physics rate) in simulated time;
* ``sum``: the sum of its terms (each Dryden term gets its own noise stream).

Headings are compass degrees the wind blows towards (0 north, 90 east). Optional spatial
variation multiplies the whole vector by ``(max(z, z_min)/h_ref)^alpha (1 + g·p)`` with z the
ENU height above the world origin (not above the local terrain).
"""

from __future__ import annotations

import math

import numpy as np

from vinecli.flight.dryden import W20_MPS, DrydenTurbulence, low_altitude_parameters
from vinecli.frames import Vec3, heading_ned_to_yaw_enu
from vinecli.specs.wind import (
    ConstantWind,
    DrydenWind,
    GustWind,
    SinusoidWind,
    SpatialShear,
    SumWind,
    WindLaw,
    WindSpec,
)

__all__ = ["WindField", "heading_unit_enu", "height_factor", "make_wind"]

_TWO_PI = 2.0 * math.pi
_Z_MIN = 0.1  # m, lower clamp of the height in the shear law


def heading_unit_enu(heading_deg: float) -> Vec3:
    """Horizontal ENU unit vector of a compass heading (deg from north, clockwise)."""
    yaw = heading_ned_to_yaw_enu(math.radians(heading_deg))
    return (math.cos(yaw), math.sin(yaw), 0.0)


class _Constant:
    def __init__(self, law: ConstantWind) -> None:
        self.v = tuple(float(c) for c in law.velocity_enu)

    def at(self, t: float) -> Vec3:
        return self.v  # type: ignore[return-value]


class _Sinusoid:
    def __init__(self, law: SinusoidWind) -> None:
        self.mean, self.amp = law.mean_mps, law.amplitude_mps
        self.w = _TWO_PI / law.period_s
        self.phase, self.start = law.phase_rad, law.start_s
        self.d = heading_unit_enu(law.heading_deg)

    def at(self, t: float) -> Vec3:
        if t < self.start:
            return (0.0, 0.0, 0.0)
        s = self.mean + self.amp * math.sin(self.w * (t - self.start) + self.phase)
        return (s * self.d[0], s * self.d[1], 0.0)


class _Gust:
    def __init__(self, law: GustWind) -> None:
        self.peak, self.start, self.dur, self.vert = law.peak_mps, law.start_s, law.duration_s, law.vertical_mps
        self.d = heading_unit_enu(law.heading_deg)

    def at(self, t: float) -> Vec3:
        x = t - self.start
        if x < 0.0 or x > self.dur:
            return (0.0, 0.0, 0.0)
        k = 0.5 * (1.0 - math.cos(_TWO_PI * x / self.dur))
        s = self.peak * k
        return (s * self.d[0], s * self.d[1], self.vert * k)


class _Dryden:
    def __init__(self, law: DrydenWind, seed: int, index: int, dt: float) -> None:
        w20 = W20_MPS[law.intensity] if law.intensity is not None else law.mean_mps
        lengths, sigmas = low_altitude_parameters(law.altitude_m, w20)
        if law.sigma_mps is not None:
            _, (s_uv, _, s_w) = low_altitude_parameters(law.altitude_m, 1.0)  # σ_w/σ_u depends on height only
            ratio = s_w / s_uv
            sigmas = (law.sigma_mps, law.sigma_mps, law.sigma_mps * ratio)
        self.params = {"length_m": lengths, "sigma_mps": sigmas, "airspeed_mps": law.airspeed_mps}
        entropy = (seed + law.seed_offset) % (1 << 64)
        rng = np.random.default_rng(np.random.SeedSequence(entropy, spawn_key=(index,)))
        self.turb = DrydenTurbulence(sigmas, lengths, law.airspeed_mps, dt, rng)
        dx, dy, _ = heading_unit_enu(law.heading_deg)
        self.dx, self.dy = dx, dy
        self.mean = law.mean_mps

    def at(self, t: float) -> Vec3:
        turb = self.turb
        n = int(t * turb.inv_dt + 1e-9)
        if turb.k < n:
            turb.advance_to(t)
        u, v, w = turb.value
        u += self.mean
        dx, dy = self.dx, self.dy
        # u along the heading, v to its left (heading rotated +90° in ENU), w up
        return (u * dx - v * dy, u * dy + v * dx, w)


def _compile(law: WindLaw, seed: int, dt: float, terms: list[object]) -> None:
    if isinstance(law, SumWind):
        for sub in law.terms:
            _compile(sub, seed, dt, terms)
    elif isinstance(law, ConstantWind):
        terms.append(_Constant(law))
    elif isinstance(law, SinusoidWind):
        terms.append(_Sinusoid(law))
    elif isinstance(law, GustWind):
        terms.append(_Gust(law))
    elif isinstance(law, DrydenWind):
        terms.append(_Dryden(law, seed, len(terms), dt))
    else:  # pragma: no cover - the spec union is closed
        raise TypeError(f"unknown wind law {type(law).__name__}")


class WindField:
    """A compiled wind law: ``velocity(t, p_enu)`` in m/s, world ENU.

    Time must not go backwards between calls (Dryden state only moves forward; an earlier
    time returns the latest state for the turbulent part).
    """

    def __init__(self, spec: WindSpec, seed: int = 0, dt: float = 1.0 / 250.0) -> None:
        self.spec = spec
        self.dt = dt
        terms: list[object] = []
        _compile(spec.law, seed, dt, terms)
        self.terms = terms
        self._ats = tuple(t.at for t in terms)  # type: ignore[attr-defined]
        self._single = self._ats[0] if len(self._ats) == 1 else None
        sp: SpatialShear | None = spec.spatial
        self._shear = sp is not None and (sp.shear_exponent != 0.0 or any(g != 0.0 for g in sp.gradient_per_m))
        if sp is not None:
            self._href, self._alpha = sp.reference_height_m, sp.shear_exponent
            self._g = tuple(float(g) for g in sp.gradient_per_m)
        self.is_constant = all(isinstance(t, _Constant) for t in terms) and not self._shear

    def velocity(self, t: float, p_enu: Vec3 = (0.0, 0.0, 0.0)) -> Vec3:
        """Wind velocity (m/s, ENU) at time t (s) and position ``p_enu`` (m)."""
        if self._single is not None:
            x, y, z = self._single(t)
        else:
            x = y = z = 0.0
            for at in self._ats:
                a, b, c = at(t)
                x += a
                y += b
                z += c
        if self._shear:
            f = 1.0
            if self._alpha != 0.0:
                f = (max(p_enu[2], _Z_MIN) / self._href) ** self._alpha
            g = self._g
            f *= 1.0 + g[0] * p_enu[0] + g[1] * p_enu[1] + g[2] * p_enu[2]
            return (f * x, f * y, f * z)
        return (x, y, z)


def height_factor(spec: WindSpec, z_enu: np.ndarray) -> np.ndarray:
    """Vectorised power-law shear factor ``(max(z, z_min) / h_ref)^α`` of ``spec`` (1 without shear), ENU z in m.

    The same height law :meth:`WindField.velocity` applies (the horizontal gradient is not included).
    """
    z = np.asarray(z_enu, dtype=np.float64)
    sp = spec.spatial
    if sp is None or sp.shear_exponent == 0.0:
        return np.ones_like(z)
    return (np.maximum(z, _Z_MIN) / sp.reference_height_m) ** sp.shear_exponent


def make_wind(spec: WindSpec, seed: int, dt: float = 1.0 / 250.0) -> WindField:
    """Compile a wind spec; ``seed`` drives Dryden noise, ``dt`` (s) is the turbulence filter step."""
    return WindField(spec, seed, dt)
