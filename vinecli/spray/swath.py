"""Effective swath of a sprayer from the deposition model (ASABE S386.2 style). Plain numpy, world ENU, SI.

A straight, level pass at a steady speed and height over flat ground is fed to the deposition
transport (:func:`~vinecli.spray.deposition.transport`, the model every run uses: nozzles, cone,
droplet classes, rotor downwash from the hover thrust, drops relaxing from the vehicle's velocity,
the forward pitch that balances the drag, the crosswind and its turbulent diffusion). Every
parcel of a steady pass lands at the same cross-track offset, so the expected cross-track pattern
is exact: each parcel spreads over its cone's disc (the chord profile ``2 sqrt(r² - u²) / (π r²)``
across the track), convolved with its diffusion Gaussian. The pattern is a distribution k(y) in 1/m
(∫ k dy = 1): a pass at flow q (L/s) and speed v (m/s) puts ``1e4 (q / v) k(y)`` L/ha on the ground.

Overlapped patterns (ASABE S386.2; ISO 23117-2 for spraying drones): copies of the pattern every
lane spacing S, alternating in direction for back-and-forth passes (the boustrophedon the planner
flies) or all the same way (racetrack); the coefficient of variation (std / mean) of the overlapped
deposit over one period. The **effective swath** is the widest spacing whose CV is at or below the
limit (default 10 %, the usual bound for an even deposit). The CV is not monotone in the spacing (an
elliptic single-pass pattern overlaps evenly near 1.57 times its half-width and poorly at narrower
spacings): :attr:`SwathPattern.good` tells whether a spacing passes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.frames import quat_from_euler
from vinecli.specs.vehicle import VehicleSpec
from vinecli.specs.wind import ConstantWind, WindSpec
from vinecli.spray.deposit_grid import flat_height
from vinecli.spray.deposition import EMIT_COLUMNS, DepositionConfig, SprayerGeometry, transport
from vinecli.spray.nozzle_pattern import inner_radius

__all__ = ["CV_LIMIT", "SwathPattern", "overlapped", "pattern_cv", "swath_pattern"]

#: default CV limit of the overlapped pattern that defines the effective swath
CV_LIMIT = 0.10
_DY = 0.01  # m, cross-track resolution of the pattern (finest; coarser for wide swaths, :func:`_resolution`)
#: cross-track samples and lane spacings a pattern keeps at most: a pattern 80 m wide or more (a spray height
#: above ~60 m, or a strong crosswind) and a swath over 20 m are sampled coarser, so the pattern of a 400 m spray
#: height (460 m wide) takes seconds, not an hour: every height a spec accepts completes
_SAMPLES = 8000
_SPACINGS = 400


@dataclass(frozen=True)
class SwathPattern:
    """Cross-track patterns of a pass and the effective swath at one height, speed and crosswind.

    ``y_m``: cross-track positions, m (world y for a pass flown along +x, i.e. left of it positive);
    ``forward`` / ``backward``: k(y), 1/m, of passes flown along +x / -x over y = 0 (the same world
    frame: a crosswind shifts both the same way); ``spacing_m`` with ``cv_back_and_forth`` /
    ``cv_racetrack`` the CV of the overlapped patterns; ``effective_m`` the effective swath.
    """

    y_m: np.ndarray
    forward: np.ndarray
    backward: np.ndarray
    spacing_m: np.ndarray
    cv_back_and_forth: np.ndarray
    cv_racetrack: np.ndarray
    effective_m: float
    cv_limit: float
    geometric_m: float
    height_agl_m: float
    speed_mps: float
    crosswind_mps: float
    pitch_deg: float
    #: largest cone footprint radius on the ground (+ 2 σ of the diffusion), m: the deposit of a pass reaches its full
    #: rate this far after the sprayer opens and tapers off over this distance after it closes
    footprint_radius_m: float = 0.0
    #: volume-weighted landing offset ahead of the nozzles along the flight direction, m (drops keep the vehicle's
    #: velocity for a while; the cone leans back with the pitch)
    along_offset_m: float = 0.0

    def good(self, spacing_m: float) -> bool:
        """Whether back-and-forth passes ``spacing_m`` apart overlap within the CV limit."""
        return pattern_cv(self, spacing_m) <= self.cv_limit

    @property
    def centre_m(self) -> float:
        """Where the plume lands across the track on average, m (mean of both pass directions): 0 in calm air, the
        crosswind's drift otherwise."""
        f = float(np.dot(self.y_m, self.forward) / self.forward.sum()) if self.forward.sum() > 0 else 0.0
        b = float(np.dot(self.y_m, self.backward) / self.backward.sum()) if self.backward.sum() > 0 else 0.0
        return 0.5 * (f + b)

    @property
    def cv_at_effective(self) -> float:
        """CV of the back-and-forth overlapped pattern at the effective swath."""
        return pattern_cv(self, self.effective_m)

    def band_mean(self, half_width_m: float, centre_m: float = 0.0) -> float:
        """Mean of the forward and backward patterns over ``centre ± half_width`` (1/m)."""
        sel = np.abs(self.y_m - centre_m) <= half_width_m + 1e-9
        if np.count_nonzero(sel) < 5:  # a band narrower than the samples (a coarse, wide pattern): interpolated
            y = centre_m + np.linspace(-half_width_m, half_width_m, 5)
            return float(0.5 * (np.interp(y, self.y_m, self.forward) + np.interp(y, self.y_m, self.backward)).mean())
        return float(0.5 * (self.forward[sel].mean() + self.backward[sel].mean()))

    def single_pass_width_m(self, band_m: float) -> float:
        """Width one pass doses at the asked rate on a band ``band_m`` wide under its centre, m:
        1 / (mean of k over the band). A single pass at flow = rate x this width x speed puts the
        asked rate on the band."""
        mean = self.band_mean(0.5 * band_m)
        return 1.0 / mean if mean > 0 else math.inf

    def dose(self, y: np.ndarray, lanes: list[tuple[float, int]]) -> np.ndarray:
        """Deposit at cross-track positions ``y`` (m) of passes at ``lanes`` [(position m, +1 along +x / -1)],
        each with unit litres per metre, 1/m: divide by the lane spacing's 1/S for the rate relative to the asked."""
        out = np.zeros(np.shape(y))
        for c, d in lanes:
            out += np.interp(np.asarray(y) - c, self.y_m, self.forward if d > 0 else self.backward, left=0.0, right=0.0)
        return out


def _drag_n(veh: VehicleSpec, v: float, mass: float, rho: float, g: float) -> float:
    """Horizontal drag at airspeed ``v`` (N): the links' c v² plus the rotors' H-force n k_d w_hover v."""
    c = sum(d.coefficient(rho) for d in veh.drag.values())
    return c * v * v + veh.n_rotors * veh.motor.k_d * veh.hover_speed(mass, g) * v


def _pass_record(veh: VehicleSpec, height_agl_m: float, speed: float, heading: float, crosswind: float,
                 rho: float, g: float, fill_fraction: float) -> tuple[np.ndarray, float]:
    """One emission record of a steady level pass along ``heading`` (rad from east), and its pitch (rad)."""
    fill = fill_fraction * (veh.tank.capacity_l if veh.tank is not None else 0.0)
    mass = veh.dry_mass() + veh.liquid_mass(fill)
    # the drag balance: pitched into the airspeed along the track, rolled into the crosswind across it (the thrust
    # tilts upwind, so the nozzles' cone leans downwind)
    pitch = math.atan2(_drag_n(veh, speed, mass, rho, g), mass * g)
    cross = crosswind * math.cos(heading)  # the wind along the body's +y (left) axis
    roll = math.copysign(math.atan2(_drag_n(veh, abs(cross), mass, rho, g), mass * g), cross)
    qx, qy, qz, qw = quat_from_euler(roll, pitch, heading)
    thrust = mass * g / (math.cos(pitch) * math.cos(roll))
    z = height_agl_m + veh.frame.landing_gear_height_m
    vx, vy = speed * math.cos(heading), speed * math.sin(heading)
    rec = np.zeros(len(EMIT_COLUMNS))
    rec[:] = (0.0, 0.0, 0.0, z, qx, qy, qz, qw, vx, vy, 0.0, 0.0, crosswind, 0.0, thrust, 1.0, 0.0)
    return rec, pitch


def _resolution(width_m: float, geometric_m: float) -> tuple[float, float]:
    """(cross-track sample step, lane spacing step), m, for a pattern ``width_m`` wide of a swath ``geometric_m``
    wide: 1 cm and 5 cm up to 80 m / 20 m, then :data:`_SAMPLES` across the pattern, :data:`_SPACINGS` up to
    the swath."""
    return max(_DY, width_m / _SAMPLES), max(0.05, geometric_m / _SPACINGS)


def _step(y: np.ndarray) -> float:
    """The sample step of the cross-track positions ``y`` (m)."""
    return float(y[1] - y[0]) if y.size > 1 else _DY


def _cross_profile(y: np.ndarray, centre: np.ndarray, radius: np.ndarray, sigma: np.ndarray,
                   vol: np.ndarray, inner: np.ndarray | None = None) -> np.ndarray:
    """Sum of disc chord profiles (centre, radius; annuli with ``inner`` radii > 0) convolved with Gaussians
    (sigma), weights ``vol``; 1/m."""
    out = np.zeros_like(y)
    dy = _step(y)
    holes = np.zeros(len(vol)) if inner is None else inner
    for c, r, s, w, ri in zip(centre, radius, sigma, vol, holes, strict=True):
        r = max(float(r), dy)
        ri = min(float(ri), 0.999 * r)
        u = y - c
        chord = 2.0 * (np.sqrt(np.maximum(r * r - u * u, 0.0)) - np.sqrt(np.maximum(ri * ri - u * u, 0.0)))
        prof = chord / (math.pi * (r * r - ri * ri))
        if s > dy:
            k = int(math.ceil(4.0 * s / dy))
            gx = np.arange(-k, k + 1) * dy
            gk = np.exp(-0.5 * (gx / s) ** 2)
            prof = np.convolve(prof, gk / gk.sum(), mode="same")
        out += w * prof
    return out


def overlapped(pattern: SwathPattern, spacing_m: float, back_and_forth: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(y m, deposit relative to its mean) over one period of passes every ``spacing_m`` (2 spacings for
    back-and-forth passes, which alternate in direction), starting at the pass over y = 0."""
    y, f, b = pattern.y_m, pattern.forward, pattern.backward
    dy = _step(y)
    n = max(1, int(round(spacing_m / dy)))
    period = 2 * n if back_and_forth else n
    idx = np.arange(y.size) - y.size // 2  # samples from the pass centre
    seg = np.bincount(idx % period, weights=f, minlength=period)
    if back_and_forth:
        seg += np.bincount((idx + n) % period, weights=b, minlength=period)
    else:
        seg = seg * 1.0
    mean = float(seg.mean())
    return np.arange(period) * dy, seg / mean if mean > 0 else seg


def pattern_cv(pattern: SwathPattern, spacing_m: float, back_and_forth: bool = True) -> float:
    """CV (std / mean) of the overlapped pattern at ``spacing_m``."""
    _y, rel = overlapped(pattern, spacing_m, back_and_forth)
    return float(np.std(rel))


# parameters: the pattern's physical inputs (vehicle, height, speed, crosswind, air, gravity, CV limit, tank fill, transport)
def swath_pattern(veh: VehicleSpec, height_agl_m: float, speed_mps: float, *, crosswind_mps: float = 0.0,
                  air_density: float = 1.225, g: float = STANDARD_GRAVITY, cv_limit: float = CV_LIMIT,
                  fill_fraction: float = 0.5, config: DepositionConfig | None = None) -> SwathPattern:
    """Patterns and effective swath of ``veh`` flying ``height_agl_m`` (skids above the ground) at ``speed_mps``
    with a crosswind (m/s, blowing towards +y, the left of a pass along +x); tank ``fill_fraction`` full.
    ``config``: the transport's options (the runs' defaults; ``drag_reach=False`` for the geometric cone)."""
    geo = SprayerGeometry.from_vehicle(veh, air_density)
    wind = WindSpec(law=ConstantWind(velocity_enu=(0.0, crosswind_mps, 0.0)))
    nz = sum(n.position_m[2] for n in veh.sprayer.nozzles) / len(veh.sprayer.nozzles)
    geometric = veh.sprayer.swath_m(max(height_agl_m + veh.frame.landing_gear_height_m + nz, 0.0))
    half = 0.5 * geometric + 4.0 + 3.0 * abs(crosswind_mps) * max(height_agl_m, 1.0)
    dy, ds = _resolution(2.0 * half, geometric)
    y = np.arange(-int(math.ceil(half / dy)), int(math.ceil(half / dy)) + 1) * dy
    profiles = []
    pitch = 0.0
    foot = along = 0.0
    for heading in (0.0, math.pi):
        rec, pitch = _pass_record(veh, height_agl_m, speed_mps, heading, crosswind_mps, air_density, g, fill_fraction)
        p = transport(rec[None, :], geo, flat_height(0.0), wind, air_density, 0, config or DepositionConfig(), g,
                      expected=True)
        k = _cross_profile(y, p.y, p.radius, p.sigma, p.vol, inner_radius(p.radius, p.ring_r))
        profiles.append(k / (k.sum() * dy))
        if heading == 0.0:  # the cone's footprint: the primaries (the far field's landing bins are drift, not it)
            near = slice(0, p.primaries)
            part_r = np.hypot(p.part_dx[near], p.part_dy[near]) if p.part_dx.size == p.vol.size else 0.0  # shapes
            foot = float(np.max(part_r + p.radius[near] + 2.0 * p.sigma[near]))
            along = float(np.dot(p.x, p.vol) / p.vol.sum()) - float(np.mean(p.path_xy[:, 0]))
    fwd, back = profiles
    spacing = np.round(np.arange(0.2, 1.6 * geometric + 1e-9, ds) * 100.0) / 100.0
    pat = SwathPattern(y, fwd, back, spacing, np.zeros(0), np.zeros(0), math.nan, cv_limit, geometric, height_agl_m,
                       speed_mps, crosswind_mps, math.degrees(pitch), foot, along)
    cv_bf = np.array([pattern_cv(pat, s, True) for s in spacing])
    cv_rt = np.array([pattern_cv(pat, s, False) for s in spacing])
    good = np.flatnonzero(cv_bf <= cv_limit)
    eff = float(spacing[good[-1]]) if good.size else math.nan
    return SwathPattern(y, fwd, back, spacing, cv_bf, cv_rt, eff, cv_limit, geometric, height_agl_m, speed_mps,
                        crosswind_mps, math.degrees(pitch), foot, along)
