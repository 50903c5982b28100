"""Distance sensor model (PX4 ``distance_sensor``, a lidar or radar altimeter): the distance from the
sensor, along its axis, to the terrain, sampled by the simulator at the sensor's rate.

The sensor sits at ``mount.position_m`` (body FLU) and measures along its mount frame's -z axis
(body down with the default mount; ``mount.rpy_deg`` tilts it). World ENU: origin ``o = p + R r``,
direction ``u = R R_mount (0, 0, -1)``. The first crossing of the ray ``o + s u`` with the terrain
``z = h(x, y)`` is found by sphere tracing on the vertical clearance ``c(s) = o_z + s u_z - h``: with
terrain slopes at most ``max_slope`` (|∇h|, from the height grid) the clearance cannot fall faster
than ``-u_z + max_slope |u_xy|`` per metre along the ray, so a step of ``c / that`` never passes the
first crossing; within 2 cm secant steps finish it to 0.1 mm. A crossing closer than ``min_range_m`` or beyond
``max_range_m`` (or none) gives an invalid sample, as a real sensor gives no usable return; a valid
distance gets white noise σ ``noise_m``. Independent noise stream per seed (no other sensor's
draws change).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from vinecli.frames import QuatXYZW, Vec3, quat_from_euler, quat_rotate
from vinecli.specs.vehicle import RangefinderSpec
from vinecli.types import RangeSample

__all__ = ["Rangefinder", "make_rangefinder", "ray_terrain_distance"]

_NAN = float("nan")
#: the rangefinder's noise stream: child 5 of the run's seed sequence (make_sensors spawns 0-3, the depth camera 7)
_SEED_CHILD = 5


def ray_terrain_distance(origin: Vec3, direction: Vec3, height: Callable[[float, float], float], max_slope: float,
                         max_range: float, tol: float = 1e-4) -> float:
    """Distance (m) along the unit ``direction`` from ``origin`` (ENU m) to the first crossing of the
    terrain ``z = height(x, y)`` with slopes at most ``max_slope``; NaN when there is none within
    ``max_range`` (or the origin is below the terrain).

    Safe sphere-tracing steps ``c / rate`` while the clearance ``c`` exceeds 2 cm, then secant steps
    on ``c(s)`` (falling back to a safe step when the clearance stops falling); a secant step that
    ends below the terrain is bisected back to the crossing."""
    ox, oy, oz = origin
    ux, uy, uz = direction
    rate = -uz + max_slope * math.sqrt(ux * ux + uy * uy)  # fastest fall of the clearance per metre
    if rate <= 0.0:
        return _NAN  # pointing up, or level over level ground: never meets it
    s = 0.0
    c = oz - height(ox, oy)
    if c < 0.0:
        return _NAN
    s_prev = c_prev = _NAN
    for _ in range(200):
        if c <= tol:
            return s
        step = c / rate
        if c < 0.02 and s_prev == s_prev and c_prev > c:
            step = c * (s - s_prev) / (c_prev - c)  # secant: where the clearance's line reaches 0
        s_prev, c_prev = s, c
        s += step
        if s > max_range:
            return _NAN
        c = oz + s * uz - height(ox + s * ux, oy + s * uy)
        if c < 0.0:  # passed the crossing (a secant step, or terrain steeper than max_slope): bisect
            lo, hi = s_prev, s
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                if oz + mid * uz - height(ox + mid * ux, oy + mid * uy) > 0.0:
                    lo = mid
                else:
                    hi = mid
                if hi - lo <= tol:
                    break
            return hi
    return s if c <= 10.0 * tol else _NAN


class Rangefinder:
    """One distance sensor (see the module docstring)."""

    def __init__(self, spec: RangefinderSpec, height: Callable[[float, float], float], max_slope: float,
                 rng: np.random.Generator) -> None:
        self.spec = spec
        self.height = height
        self.max_slope = max_slope
        self.period_us = max(1, round(1e6 / spec.rate_hz))
        self._last_k = -1
        self._rng = rng
        r, p, y = spec.mount.rpy_deg
        q = quat_from_euler(math.radians(r), math.radians(p), math.radians(y))
        self.axis_flu: Vec3 = quat_rotate(q, (0.0, 0.0, -1.0))
        pm = spec.mount.position_m
        self.r_flu: Vec3 = (float(pm[0]), float(pm[1]), float(pm[2]))
        self.noise = spec.noise_m
        self.min_range = spec.min_range_m
        self.max_range = spec.max_range_m
        self.last: RangeSample | None = None

    def true_distance(self, pos: Vec3, quat: QuatXYZW) -> float:
        """Noise-free distance (m) along the axis from the sensor at body pose (``pos`` ENU m,
        ``quat`` FLU -> ENU) to the terrain; NaN when it sees none within the maximum range."""
        rx, ry, rz = quat_rotate(quat, self.r_flu)
        o = (pos[0] + rx, pos[1] + ry, pos[2] + rz)
        return ray_terrain_distance(o, quat_rotate(quat, self.axis_flu), self.height, self.max_slope, self.max_range)

    def sample(self, t_us: int, pos: Vec3, quat: QuatXYZW) -> RangeSample | None:
        """A reading at ``t_us`` when one is due (integer-µs rate grid), else None."""
        k = t_us // self.period_us
        if k <= self._last_k:
            return None
        self._last_k = k
        d = self.true_distance(pos, quat)
        if d == d and self.noise > 0.0:
            d += self.noise * float(self._rng.standard_normal())
        if not (self.min_range <= d <= self.max_range):  # NaN: no return
            s = RangeSample(t_us, _NAN, False)
        else:
            s = RangeSample(t_us, d, True)
        self.last = s
        return s


def make_rangefinder(spec: RangefinderSpec | None, height: Callable[[float, float], float], max_slope: float,
                     seed: int) -> Rangefinder | None:
    """The vehicle's rangefinder over terrain ``height`` (ENU m) with its own noise stream, or None."""
    if spec is None:
        return None
    ss = np.random.SeedSequence(seed % (1 << 64), spawn_key=(_SEED_CHILD,))
    return Rangefinder(spec, height, max_slope, np.random.default_rng(ss))
