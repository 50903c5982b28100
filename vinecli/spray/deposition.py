"""Spray transport: where the emitted liquid lands (docs/deposition.md). Plain numpy, no PyBullet.

The loop sums the emitted volume over up to 0.04 s of spraying steps and calls
:meth:`SprayEmitter.emit` once per such group (one tuple append). :func:`transport` then moves everything in bulk, vectorised:

1. steps are grouped into bins of ``group_s`` (volume summed, state volume-weighted);
2. each group's volume is split over the nozzles (``flow_share``) and the equal-volume droplet size
   classes: one parcel each, spread on landing over a disc (:func:`~vinecli.spray.deposit_grid.rasterise_discs`):
   the class's ballistic reach from the nozzle (at most the cone, h tan(θ/2)) spread by the rotor wake that
   carries it down (:mod:`vinecli.spray.wake`);
3. each parcel falls from its nozzle (world ENU from the body pose) to the terrain: fall time
   through the rotor downwash (:mod:`vinecli.spray.downwash`, momentum theory from the
   recorded rotor thrust and the airspeed), at terminal velocity (:mod:`vinecli.spray.droplets`);
4. horizontally the cone centre follows the tilted nozzle axis; the parcel moves with the
   wind at mid-fall height (wind of the release time incl. gusts and Dryden, shear law of the
   world), relaxes from the vehicle's velocity with τ = v_t / g, and spreads by turbulent
   diffusion σ = sqrt(2 K T) with a surface-layer eddy diffusivity ``K = κ u* z``;
5. the landing height is the terrain under the landing point (two fixed-point passes).

Volume is conserved exactly: every parcel lands somewhere (on or off the grid).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.frames import quat_rotate_many
from vinecli.specs.vehicle import VehicleSpec
from vinecli.specs.wind import WindSpec
from vinecli.spray.downwash import crossflow_bending, fall_time_s, induced_velocity, wake_velocity
from vinecli.spray.droplets import (
    AIR_DENSITY,
    AIR_VISCOSITY,
    WATER_DENSITY,
    relaxation_time_s,
    size_classes_m,
    terminal_velocity,
)
from vinecli.spray.nozzle_pattern import FULL_CONE, PATTERN_CODES, expand_parts, part_counts, variance_factor
from vinecli.spray.wake import ballistic_reach_m, exit_speed_mps, wake_half_width_m, wake_spread_sigma_m
from vinecli.spray.wake_escape import stripped_share, wake_edge_radius_m

__all__ = ["EMIT_COLUMNS", "DepositionConfig", "Parcels", "SprayEmitter", "SprayerGeometry", "fan_axes_flu", "transport"]

#: one record: time s, CoM position m ENU, attitude quaternion xyzw (FLU -> ENU), velocity m/s ENU,
#: wind m/s ENU at the CoM, total rotor thrust N, emitted volume L, and how long before ``t_s`` the
#: volume left the nozzles on average, s (0 for one step; the loop sums up to 0.04 s per record)
EMIT_COLUMNS = ("t_s", "px", "py", "pz", "qx", "qy", "qz", "qw", "vx", "vy", "vz", "wx", "wy", "wz", "thrust_n", "vol_l",
                "lag_s")
KARMAN = 0.41
MIN_LIFTED_SHARE = 0.01  # a parcel's share lifted by the outwash below this lands with the parcel
LIFT_BIN_S = 0.2  # lifted parcels merged over this much release time, s (about a metre of flight: their discs, at
# least the wall jet's W/2, overlap along the track)
#: the far field's parcels a run holds at most (each lifted parcel becomes up to FAR_BINS): a long run, or one in
#: wind, where every merged parcel lands in FAR_BINS bins, merges its lifted parcels over longer windows (60,000 let
#: a 94 s crosswind spray merge over 3.2 s = 6.4 m of flight: hot spots 1.66x that often; 150,000 keeps it at 0.8 s
#: there, and the bundled job's memory bound, which counts the budget's work per far parcel and hedge, at 1.43 GB)
MAX_FAR_PARCELS = 150_000
FAR_BINS = 65  # landing bins per lifted parcel at most (spray/surface_layer.py LOG_BINS + the airborne share)
STRIP_LAYER_M = 0.25  # the wake edge's release layer (the nozzles' height) in steps of this, m
FAR_WALL_JET, FAR_STRIPPED = 1, 2  # Parcels.far_kind of the far field's parcels


@dataclass(frozen=True)
class DepositionConfig:
    """Numerical and model options (defaults used in every spray run)."""

    cell_m: float = 0.1  # deposition grid cell, m
    margin_m: float = 15.0  # grid extends this far beyond the sprayed path and the rows, m
    max_cells: int = 6_000_000  # the cell doubles when the area needs more
    max_fft_cells: int = 8_000_000  # ... or when the padded disc convolution (footprint) needs more
    group_s: float = 0.04  # emission steps binned per transport group, s
    downwash: bool = True
    diffusion: bool = True
    roughness_m: float = 0.1  # aerodynamic roughness of the crop for u*, m
    outwash: bool = True  # drops the wake does not drive into the ground follow the outwash (spray/outwash.py)
    #: drag stops the drops' sideways motion (ballistic reach, spray/wake.py); False: they fly on along the cone
    drag_reach: bool = True
    #: Obukhov length of the surface layer the far-field drift crosses, m (inf: neutral; > 0 stable, < 0 unstable)
    obukhov_m: float = math.inf
    #: the crop's zero-plane displacement, m (2/3 of the hedges' height in a vineyard; 0: bare ground): the far field's
    #: wind profile starts there, and drops released below it settle among the plants (spray/outwash.py)
    displacement_m: float = 0.0


@dataclass(frozen=True)
class SprayerGeometry:
    """What transport needs of the vehicle: nozzles (body FLU), droplet classes, rotors."""

    nozzles_flu: np.ndarray  # (n, 3) m
    shares: np.ndarray  # (n,) sum 1
    tan_half: np.ndarray  # (n,) tan(cone angle / 2)
    diam_m: np.ndarray  # (c,) class diameters
    fractions: np.ndarray  # (c,) volume fractions, sum 1
    v_t: np.ndarray  # (c,) terminal velocities, m/s
    n_rotors: int
    rotor_radius_m: float
    rotor_plane_z: float  # mean rotor hub z, m body FLU
    exit_speed_mps: float = 24.5  # liquid speed leaving the nozzles (Bernoulli at the rated pressure, 3 bar), m/s
    arm_m: float = 0.0  # the rotor hubs' mean distance from the vehicle's axis, m (the wake's edge: spray/wake_escape.py)
    #: (n,) each nozzle's spray pattern (spray/nozzle_pattern.py: FULL_CONE, HOLLOW_CONE, FLAT_FAN; None: full cones)
    pattern: np.ndarray | None = None
    #: (n, 3) each flat fan's sheet axis, body FLU (unit; None: across the vehicle, +y)
    fan_axis_flu: np.ndarray | None = None

    def patterns(self) -> np.ndarray:
        """(n,) the nozzles' pattern codes (full cones when not given)."""
        n = self.nozzles_flu.shape[0]
        return np.full(n, FULL_CONE, dtype=np.int64) if self.pattern is None else np.asarray(self.pattern, np.int64)

    @classmethod
    def from_vehicle(cls, veh: VehicleSpec, air_density: float) -> SprayerGeometry:
        sp = veh.sprayer
        noz = np.array([n.position_m for n in sp.nozzles], dtype=np.float64)
        shares = np.array([n.flow_share for n in sp.nozzles], dtype=np.float64)
        d, frac = size_classes_m(sp.droplets.vmd_um, sp.droplets.gsd, sp.droplets.classes)
        return cls(
            nozzles_flu=noz, shares=shares / shares.sum(),
            tan_half=np.tan(np.radians([n.cone_angle_deg for n in sp.nozzles]) / 2.0),
            diam_m=d, fractions=frac, v_t=terminal_velocity(d, WATER_DENSITY, air_density, AIR_VISCOSITY),
            n_rotors=veh.n_rotors, rotor_radius_m=0.5 * veh.motor.prop_diameter_m,
            rotor_plane_z=float(np.mean([r.position_m[2] for r in veh.rotors])),
            exit_speed_mps=exit_speed_mps(sp.rated_pressure_bar),
            arm_m=float(np.mean([math.hypot(r.position_m[0], r.position_m[1]) for r in veh.rotors])),
            pattern=np.array([PATTERN_CODES[n.pattern] for n in sp.nozzles], dtype=np.int64),
            fan_axis_flu=fan_axes_flu([n.fan_axis_deg for n in sp.nozzles]),
        )


def fan_axes_flu(fan_axis_deg: list[float] | tuple[float, ...]) -> np.ndarray:
    """(n, 3) unit sheet axes in the body frame FLU of fans at ``fan_axis_deg`` from forward towards the left."""
    a = np.radians(np.asarray(fan_axis_deg, dtype=np.float64))
    return np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1)


class SprayEmitter:
    """Records of the sprayer state (the loop's only cost); ``emit`` is a bound list append."""

    def __init__(self) -> None:
        self.rows: list[tuple[float, ...]] = []
        #: emit((t, px, py, pz, qx, qy, qz, qw, vx, vy, vz, wx, wy, wz, thrust_n, vol_l, lag_s)) -- see EMIT_COLUMNS
        self.emit: Callable[[tuple[float, ...]], None] = self.rows.append

    def array(self) -> np.ndarray:
        """(N, 17) float64 records."""
        n = len(EMIT_COLUMNS)
        flat = np.fromiter(itertools.chain.from_iterable(self.rows), dtype=np.float64, count=len(self.rows) * n)
        return flat.reshape(-1, n)

    @property
    def emitted_l(self) -> float:
        return float(sum(r[15] for r in self.rows))


@dataclass
class Parcels:
    """Landed parcels: centre x, y (m ENU), volume (L), size class, footprint radius (m); nozzle path (m ENU);
    fall time (s) and velocity on landing (m/s; the spray budget's path through the canopy).

    A parcel's volume is spread uniformly over the disc of its ``radius`` around (x, y) (the cone).
    """

    x: np.ndarray
    y: np.ndarray
    vol: np.ndarray
    cls: np.ndarray
    path_xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    emitted_l: float = 0.0
    radius: np.ndarray = field(default_factory=lambda: np.zeros(0))  # cone footprint radius at landing, m
    t_fall: np.ndarray = field(default_factory=lambda: np.zeros(0))  # fall time, s
    vx_land: np.ndarray = field(default_factory=lambda: np.zeros(0))  # horizontal velocity on landing, m/s ENU
    vy_land: np.ndarray = field(default_factory=lambda: np.zeros(0))
    vz_land: np.ndarray = field(default_factory=lambda: np.zeros(0))  # fall speed on landing (down positive), m/s
    group: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # emission group (path_xy row)
    primaries: int = 0  # the first ``primaries`` parcels: one per (group, nozzle, size class), in that order
    sigma: np.ndarray = field(default_factory=lambda: np.zeros(0))  # σ of the turbulent-diffusion offset, m
    #: the footprint's parts (spray/wake.py): ``radius² = reach² + wake_var``; the ballistic reach (m) is reached
    #: just below the nozzle, the wake's spreading (variance term 4σ², m²) grows with the fall from ``release_h`` (m
    #: above the ground): the plume is narrower higher up (0 / 0: parallel paths, the far-field drift's parcels)
    reach: np.ndarray = field(default_factory=lambda: np.zeros(0))
    wake_var: np.ndarray = field(default_factory=lambda: np.zeros(0))
    release_h: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: the wake that carried the parcel: induced velocity at the rotors (m/s, 0: none) and the nozzles' depth below
    #: them (m); with ``rotor_radius_m`` the downwash at any height (:func:`vinecli.spray.downwash.wake_velocity`)
    wake_vi: np.ndarray = field(default_factory=lambda: np.zeros(0))
    wake_zeta0: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rotor_radius_m: float = 0.0
    #: how the crossflow bent the wake over: 1 / its momentum length (1/m, 0: still air; spray/downwash.py)
    wake_bend: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: how each far-field parcel left the wake (FAR_WALL_JET, FAR_STRIPPED; 0 for the primaries) and the primary
    #: parcel it stands for (-1 for the primaries): the wall jet's drops crossed that parcel's canopy on the way down
    far_kind: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int8))
    source: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    #: the nozzles' patterns (spray/nozzle_pattern.py): a flat fan's parts, where each sits from the centre of its line
    #: (m ENU), and a hollow cone's ring, the mean radius of the annulus it lands on (m; 0: a disc, whose inner radius
    #: is 2 ring_r - radius); empty when every nozzle is a full cone
    part_dx: np.ndarray = field(default_factory=lambda: np.zeros(0))
    part_dy: np.ndarray = field(default_factory=lambda: np.zeros(0))
    ring_r: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def downwash_at(self, z_m: float | np.ndarray, index: np.ndarray | slice = slice(None)) -> np.ndarray:
        """The wake's downward speed (m/s) ``z_m`` above the ground where the parcels ``index`` fell through it."""
        zeta = self.wake_zeta0[index] + np.maximum(self.release_h[index] - z_m, 0.0)
        bend = self.wake_bend[index] if self.wake_bend.size == self.wake_vi.size else 0.0
        return wake_velocity(zeta, self.wake_vi[index], max(self.rotor_radius_m, 1e-6), bending=bend)


def _groups(rec: np.ndarray, group_s: float) -> np.ndarray:
    """Volume-weighted means per time bin of the release time; (G, 17) with the summed volume in column 15.

    The release positions are moved back along the velocity by each record's lag first.
    """
    rec = rec.copy()
    rec[:, 1:4] -= rec[:, 8:11] * rec[:, 16:17]
    rec[:, 0] -= rec[:, 16]
    rec[:, 16] = 0.0
    gid = np.floor(rec[:, 0] / group_s + 1e-9).astype(np.int64)  # records are in time order
    inv = np.concatenate([[0], np.cumsum(gid[1:] != gid[:-1])])
    vol = rec[:, 15]
    vsum = np.bincount(inv, weights=vol)
    wsum = np.where(vsum > 0, vsum, 1.0)
    out = np.empty((vsum.size, rec.shape[1]))
    for j in range(rec.shape[1]):
        out[:, j] = np.bincount(inv, weights=rec[:, j] * vol) / wsum
    out[:, 15] = vsum
    q = out[:, 4:8]
    out[:, 4:8] = q / np.linalg.norm(q, axis=1, keepdims=True)
    return out


# parameters: the records and the sprayer, the terrain, wind and air of the run, its seed, then options with
# their defaults
def transport(records: np.ndarray, geo: SprayerGeometry, height: Callable[[np.ndarray, np.ndarray], np.ndarray],
              wind_spec: WindSpec, air_density: float, seed: int, config: DepositionConfig = DepositionConfig(),
              g: float = STANDARD_GRAVITY, expected: bool = False) -> Parcels:
    """Landing points of everything in ``records`` ((N, 17), :data:`EMIT_COLUMNS`). Deterministic per seed.

    ``expected``: no random diffusion offset (each parcel at the centre of its Gaussian, whose σ is in
    ``Parcels.sigma``), for expected patterns (:mod:`vinecli.spray.swath`)."""
    from vinecli.flight.wind import height_factor

    rec = np.asarray(records, dtype=np.float64).reshape(-1, len(EMIT_COLUMNS))
    rec = rec[rec[:, 15] > 0.0]
    emitted = float(rec[:, 15].sum())
    if rec.shape[0] == 0:
        z = np.zeros(0)
        return Parcels(z, z, z, z.astype(np.int64), np.zeros((0, 2)), 0.0, z, z)
    grp = _groups(rec, config.group_s)
    ng = grp.shape[0]
    p, q, v, wnd = grp[:, 1:4], grp[:, 4:8], grp[:, 8:11], grp[:, 11:14]
    thrust, vol = grp[:, 14], grp[:, 15]
    nn, nc = geo.nozzles_flu.shape[0], geo.v_t.size

    # nozzle positions and cone axes, world ENU: (G, n, 3)
    pn = np.stack([p + quat_rotate_many(q, geo.nozzles_flu[i]) for i in range(nn)], axis=1)
    axis = quat_rotate_many(q, np.array([0.0, 0.0, -1.0]))
    az = np.minimum(axis[:, 2], -0.2)  # nozzles pointing near-horizontal: cap the lean at ~78 deg
    lean = np.stack([axis[:, 0] / -az, axis[:, 1] / -az], axis=1)  # horizontal offset per metre of fall (G, 2)
    zg0 = height(pn[..., 0], pn[..., 1])
    h0 = np.maximum(pn[..., 2] - zg0, 0.0)  # (G, n)

    # rotor downwash (momentum theory with the recorded thrust and the horizontal airspeed)
    air_h = np.hypot(wnd[:, 0] - v[:, 0], wnd[:, 1] - v[:, 1])
    if config.downwash:
        v_i = induced_velocity(thrust / geo.n_rotors, air_density, geo.rotor_radius_m, air_h)
    else:
        v_i = np.zeros(ng)
    bend = crossflow_bending(thrust, air_density, air_h)  # the wake in the crossflow of the airspeed (G,)
    zeta0 = np.maximum(geo.rotor_plane_z - geo.nozzles_flu[:, 2], 0.0)  # (n,)

    # wind at mid-fall height (release-time wind incl. gusts/Dryden, scaled by the shear law)
    z_mid = 0.5 * (pn[..., 2] + zg0)
    ratio = height_factor(wind_spec, z_mid) / height_factor(wind_spec, p[:, 2])[:, None]  # (G, n)
    ux, uy = wnd[:, 0, None] * ratio, wnd[:, 1, None] * ratio  # (G, n)

    vt = geo.v_t
    tau = relaxation_time_s(vt, g)
    t_fall, s_end = fall_time_s(h0[..., None], zeta0[None, :, None], vt[None, None, :], v_i[:, None, None],
                                wnd[:, 2, None, None], geo.rotor_radius_m, bending=bend[:, None, None])  # (G, n, c)

    # eddy diffusivity K = κ u* z (neutral surface layer), u* from the log law at the release height
    if config.diffusion:
        zr = np.maximum(h0, 2.0 * config.roughness_m)
        ustar = KARMAN * np.hypot(ux, uy) / np.log(zr / config.roughness_m)
        kdiff = KARMAN * ustar * np.maximum(0.5 * h0, config.roughness_m)  # (G, n) m²/s
    else:
        kdiff = np.zeros_like(h0)

    # parcels: one per (group, nozzle, size class); the cone spreads each over a disc of radius h tan(θ/2)
    shape = (ng, nn, nc)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0xDE905,)))
    noise = rng.standard_normal((2, *shape)) if config.diffusion and not expected else np.zeros((2, *shape))
    tau3 = tau[None, None, :]

    def land(hh: np.ndarray, tt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lag = tau3 * (1.0 - np.exp(-tt / tau3))
        sig = np.sqrt(2.0 * kdiff[..., None] * tt)
        xs = (pn[..., 0, None] + hh * lean[:, None, None, 0] + ux[..., None] * tt
              + (v[:, 0, None, None] - ux[..., None]) * lag + sig * noise[0])
        ys = (pn[..., 1, None] + hh * lean[:, None, None, 1] + uy[..., None] * tt
              + (v[:, 1, None, None] - uy[..., None]) * lag + sig * noise[1])
        return xs, ys

    h3 = np.broadcast_to(h0[..., None], shape)
    x, y = land(h3, t_fall)
    # second pass: the terrain under the landing point sets the fall height
    h1 = np.maximum(pn[..., 2, None] - height(x, y), 0.0)
    t1 = np.maximum(t_fall + (h1 - h3) / s_end, 0.0)
    x, y = land(h1, t1)

    vp = vol[:, None, None] * geo.shares[None, :, None] * geo.fractions[None, None, :]
    reach, wake_var = _footprint(geo, h1, t1, air_density, config)
    radius = np.sqrt(reach * reach + wake_var)
    cls = np.broadcast_to(np.arange(nc)[None, None, :], shape)
    relax = np.exp(-t1 / tau3)  # share of the vehicle's velocity (relative to the air) the drops still carry
    vxl = ux[..., None] + (v[:, 0, None, None] - ux[..., None]) * relax
    vyl = uy[..., None] + (v[:, 1, None, None] - uy[..., None]) * relax

    def flat(a: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(np.broadcast_to(a, shape)).ravel()

    sig = np.sqrt(2.0 * kdiff[..., None] * t1)
    out = Parcels(x.ravel(), y.ravel(), flat(vp), flat(cls), pn.mean(axis=1)[:, :2], emitted, radius.ravel(), flat(t1),
                  flat(vxl), flat(vyl), flat(s_end), flat(np.arange(ng)[:, None, None]), ng * nn * nc, flat(sig),
                  flat(reach), flat(wake_var), flat(h1), flat(v_i[:, None, None]), flat(zeta0[None, :, None]),
                  geo.rotor_radius_m, flat(bend[:, None, None]), np.zeros(ng * nn * nc, dtype=np.int8),
                  np.full(ng * nn * nc, -1, dtype=np.int64))
    if config.downwash and config.outwash:
        # the crosswind strips the wake's edge (spray/wake_escape.py): the class's disc around its nozzle, moved by
        # the drops' lag behind the air, beyond the wake's edge
        lag = tau3 * (1.0 - relax)
        off = ((pn[..., 0] - p[:, 0, None])[..., None] + (v[:, 0, None, None] - ux[..., None]) * lag,
               (pn[..., 1] - p[:, 1, None])[..., None] + (v[:, 1, None, None] - uy[..., None]) * lag)
        w_mid = wake_velocity(zeta0[None, :, None] + 0.5 * h1, v_i[:, None, None], geo.rotor_radius_m,
                              bending=bend[:, None, None])
        air_rel = ((ux - v[:, 0, None])[..., None], (uy - v[:, 1, None])[..., None])  # the air past the vehicle
        strip = np.zeros(np.shape(radius))  # the cones alone (drag_reach off): no wake edge to strip
        if config.drag_reach:
            # a ring or a line reaches further out than a disc of the same reach: the disc of the pattern's variance
            shaped = np.sqrt(variance_factor(geo.patterns())[None, :, None] * reach * reach + wake_var)
            strip = stripped_share(shaped, off, air_rel, (v[:, 0, None, None], v[:, 1, None, None]), t1,
                                   wake_edge_radius_m(geo.arm_m, geo.rotor_radius_m), w_mid, tau3, h1)
        _add_lifted(out, flat(np.maximum(s_end - vt[None, None, :], 0.0)), flat(np.broadcast_to(strip, t1.shape)), geo,
                    height, wnd, p[:, 2], config)
    _shape_patterns(out, geo, q, reach, wake_var)
    return out


def _shape_patterns(out: Parcels, geo: SprayerGeometry, q: np.ndarray, reach: np.ndarray,
                    wake_var: np.ndarray) -> None:
    """Hollow cones' rings and flat fans' lines (spray/nozzle_pattern.py): each primary parcel of such a nozzle lands
    on its shape (an annulus, or parts along the sheet turned by the body's attitude ``q`` (G, 4) of each group)."""
    pattern = geo.patterns()
    if not np.any(pattern != FULL_CONE) or out.primaries == 0:
        return
    lengths = part_counts(pattern, reach, wake_var)
    fan = geo.fan_axis_flu if geo.fan_axis_flu is not None else fan_axes_flu([90.0] * pattern.size)
    axes = np.stack([quat_rotate_many(q, fan[j])[:, :2] for j in range(pattern.size)], axis=1)  # (G, n, 2) the sheets
    norm = np.linalg.norm(axes, axis=2, keepdims=True)
    axes = np.where(norm > 1e-9, axes / np.maximum(norm, 1e-12), np.array([1.0, 0.0]))
    expand_parts(out, pattern, lengths, axes)


def _footprint(geo: SprayerGeometry, h: np.ndarray, t_fall: np.ndarray, air_density: float,
               config: DepositionConfig) -> tuple[np.ndarray, np.ndarray]:
    """(G, n, c) footprint on the ground (:mod:`vinecli.spray.wake`): the ballistic reach of each nozzle's drop
    classes (at most the cone at that height), m, and the wake's spreading as the disc's variance term 4σ², m²."""
    cone = h * geo.tan_half[None, :, None]
    if not config.drag_reach:
        return cone, np.zeros_like(cone)
    # the drops fly out along the cone's rays at the exit speed and drag acts on their whole speed (its Reynolds
    # number is the full speed's): the ray's stopping distance, projected sideways by sin(θ/2)
    sideways = np.sin(np.arctan(geo.tan_half))  # (n,)
    along = ballistic_reach_m(geo.diam_m, geo.exit_speed_mps, air_density)  # (c,)
    reach = sideways[:, None] * along[None, :]  # (n, c)
    carried = h - geo.v_t[None, None, :] * t_fall  # the air's share of the fall
    sigma = wake_spread_sigma_m(wake_half_width_m(geo.rotor_radius_m, geo.n_rotors), carried)
    return np.minimum(cone, reach[None, :, :]), 4.0 * sigma * sigma


def _class_speed_range(geo: SprayerGeometry) -> np.ndarray:
    """(c, 2) terminal velocities (m/s) at the edges of each size class: the geometric means of neighbouring
    classes' diameters, the outer edges as far out as the nearest neighbour (one class: its own speed)."""
    d = np.asarray(geo.diam_m, dtype=np.float64)
    if d.size < 2:
        return np.stack([geo.v_t, geo.v_t], axis=1)
    inner = np.sqrt(d[:-1] * d[1:])
    edges = np.concatenate([[d[0] * d[0] / inner[0]], inner, [d[-1] * d[-1] / inner[-1]]])
    vt = terminal_velocity(edges, WATER_DENSITY, AIR_DENSITY, AIR_VISCOSITY)
    return np.stack([vt[:-1], vt[1:]], axis=1)


def _add_lifted(out: Parcels, jet_speed: np.ndarray, stripped: np.ndarray, geo: SprayerGeometry,
                height: Callable[[np.ndarray, np.ndarray], np.ndarray], wnd: np.ndarray, z_release: np.ndarray,
                config: DepositionConfig) -> None:
    """Move what the wake does not drive into the ground to the far field (:mod:`vinecli.spray.surface_layer`):
    the share of each parcel ``stripped`` at the wake's edge by the crossflow (:mod:`vinecli.spray.wake_escape`;
    released between the ground and the nozzles, from the wake's edge) and, of the rest, the fine drops that follow
    the wall jet (:mod:`vinecli.spray.outwash`; released up to the jet's diameter W, W/2 downwind)."""
    from vinecli.spray.outwash import impaction_share

    jet = 2.0 * geo.rotor_radius_m * math.sqrt(geo.n_rotors)
    n = out.vol.size
    strip = np.where(stripped >= MIN_LIFTED_SHARE, out.vol * stripped, 0.0)
    rest = out.vol - strip
    share = 1.0 - impaction_share(geo.diam_m[out.cls], jet_speed, jet)
    wall = np.where(share >= MIN_LIFTED_SHARE, rest * share, 0.0)  # smaller shares stay with the parcel
    out.vol = rest - wall
    edge = wake_edge_radius_m(geo.arm_m, geo.rotor_radius_m)
    # the edge's release layer: the nozzles' height, in steps of STRIP_LAYER_M (the far field's ensembles are cached
    # per layer)
    layer = np.maximum(np.round(out.release_h[:n] / STRIP_LAYER_M), 1.0) * STRIP_LAYER_M
    for kind, lifted, top, offset, t_left in (
            (FAR_WALL_JET, wall, np.full(n, jet), np.full(n, 0.5 * jet), out.t_fall[:n]),
            (FAR_STRIPPED, strip, layer, np.full(n, edge), 0.5 * out.t_fall[:n])):
        _release(out, kind, lifted, top, offset, t_left, geo, height, wnd, z_release, config)


# parameters: one escape route's release (volumes, layer top, offset, time left, kind) and the transport's context
def _release(out: Parcels, kind: int, lifted: np.ndarray, top: np.ndarray, offset: np.ndarray, t_left: np.ndarray,
             geo: SprayerGeometry, height: Callable[[np.ndarray, np.ndarray], np.ndarray], wnd: np.ndarray,
             z_release: np.ndarray, config: DepositionConfig) -> None:
    """Append the far field's parcels of ``lifted`` (L per primary parcel), released between the ground and ``top``
    (m), ``offset`` (m) downwind of each parcel's landing point, ``t_left`` (s) after the release."""
    from vinecli.spray.outwash import lifted_parcels

    src = np.flatnonzero(lifted > 0.0)
    if src.size == 0:
        return
    # lifted parcels of the same nozzle, size class and release layer are merged over LIFT_BIN_S of release time
    # (volume-weighted landing point, fall time, release conditions): the far field's plume is smooth
    per_group = out.group.size and (out.primaries // max(int(out.group[:out.primaries].max()) + 1, 1))
    layer_key = np.unique(top[src], return_inverse=True)[1]
    # a merged parcel becomes FAR_BINS landing bins, one in still air (outwash.lifted_parcels: nothing carries it)
    bins = np.where(np.hypot(wnd[out.group[src], 0], wnd[out.group[src], 1]) > 0.0, FAR_BINS, 1)
    bin_s = LIFT_BIN_S
    for _ in range(12):  # a long run: merged over longer windows so the far field stays within MAX_FAR_PARCELS
        key = ((out.group[src] * config.group_s // bin_s).astype(np.int64) * per_group + src % per_group) * (
            int(layer_key.max()) + 1) + layer_key
        uk, inv = np.unique(key, return_inverse=True)
        per_set = np.zeros(uk.size, dtype=np.int64)
        np.maximum.at(per_set, inv, bins)
        if int(per_set.sum()) <= MAX_FAR_PARCELS:
            break
        bin_s *= 2.0
    w = lifted[src]
    wsum = np.bincount(inv, weights=w)

    def merged(a: np.ndarray) -> np.ndarray:
        return np.bincount(inv, weights=a[src] * w) / wsum

    first = np.full(uk.size, src.size)
    np.minimum.at(first, inv, np.arange(src.size))
    rep = src[first]  # a parcel of each merged set: its size class, (first) emission group and release layer
    mx, my, mt = merged(out.x), merged(out.y), merged(t_left)
    g = out.group[rep]
    # the drops leave the wake from under the whole footprint (the wall jet forms under it; the edge's drops were on
    # its outer part): each landing bin spreads at least over the parcel's own disc
    spread = np.maximum(offset[rep], merged(out.radius))
    sec = lifted_parcels(mx, my, wsum, _class_speed_range(geo)[out.cls[rep]], mt, wnd[g, 0], wnd[g, 1],
                         np.maximum(z_release[g] - height(mx, my), 2.0 * config.roughness_m), config.roughness_m,
                         top[rep], config.obukhov_m, offset[rep], config.displacement_m, spread)
    k = rep[sec["src"]]
    out.x = np.concatenate([out.x, sec["x"]])
    out.y = np.concatenate([out.y, sec["y"]])
    out.vol = np.concatenate([out.vol, sec["vol"]])
    out.cls = np.concatenate([out.cls, out.cls[k]])
    out.radius = np.concatenate([out.radius, sec["radius"]])
    out.t_fall = np.concatenate([out.t_fall, sec["t_fall"]])
    out.vx_land = np.concatenate([out.vx_land, sec["vx"]])
    out.vy_land = np.concatenate([out.vy_land, sec["vy"]])
    out.vz_land = np.concatenate([out.vz_land, sec["vz"]])
    out.group = np.concatenate([out.group, out.group[k]])
    out.sigma = np.concatenate([out.sigma, np.zeros(k.size)])  # the far field's spread is in its landing points
    out.reach = np.concatenate([out.reach, sec["radius"]])
    out.wake_var = np.concatenate([out.wake_var, np.zeros(k.size)])
    out.release_h = np.concatenate([out.release_h, np.zeros(k.size)])
    out.wake_vi = np.concatenate([out.wake_vi, np.zeros(k.size)])
    out.wake_zeta0 = np.concatenate([out.wake_zeta0, np.zeros(k.size)])
    out.wake_bend = np.concatenate([out.wake_bend, np.zeros(k.size)])
    out.far_kind = np.concatenate([out.far_kind, np.full(k.size, kind, dtype=np.int8)])
    out.source = np.concatenate([out.source, k.astype(np.int64)])
