"""Fine drops the rotor wake does not drive into the ground: lifted by the outwash, then carried by the wind.

The vehicle's downwash reaches the ground as a jet of diameter ``W`` (the rotors' merged wake,
``W = D_prop √n_rotors``) at the speed ``U`` the fall model has there. Like particles in an inertial
impactor, drops with enough inertia cross the jet's turn and hit the ground; the others follow the
air into the radial outwash. The share that impacts is the round-jet impactor efficiency against
``Stk = ρ_w d² U / (9 μ W)``, 50 % at ``√Stk50 = 0.49`` (Marple & Willeke 1976, in *Fine Particles*,
Liu ed., Academic Press; Hinds, *Aerosol Technology*, 2nd ed., §5.5). The shape around the cut is this
model's assumption: a logistic in ``√Stk`` going from 10 % to 90 % over ±0.1 (a sharp impactor).

The drops that follow the outwash leave the wall jet ``W/2`` downwind of their landing point, spread evenly
between the ground and the height ``W`` (the recirculating ground vortex of a rotor's wall jet reaches
about a wake diameter up, as the ground vortex of a helicopter in ground effect reaches the rotor's height:
Curtiss et al. 1984, J. Am. Helicopter Soc. 29(1)), and the surface layer carries them
(:mod:`vinecli.spray.surface_layer`: wind profile, turbulence, settling). Each lifted parcel becomes one
parcel per bin of its landing density (at the bin's middle, spread over a disc overlapping its neighbours),
plus one for the share still airborne beyond the far-field model's reach.

**The canopy air is exchanged with the air above.** Drops released below the crop's zero-plane displacement ``d``
are among the hedges, where the wind is slow (:data:`CANOPY_ATTENUATION`). They do not all settle there: the
canopy's coherent eddies (the mixing-layer eddies at the canopy top, Raupach, Finnigan & Brunet 1996,
Boundary-Layer Meteorol. 78:351; Finnigan 2000, Annu. Rev. Fluid Mech. 32:519) exchange the canopy air with the
surface layer at the transfer velocity ``w_e = u*² / U_h = β u*`` (the momentum flux carried through the canopy top
by the wind there; ``β = u*/U_h ≈ 0.3`` for dense canopies, Raupach et al. 1996; Harman & Finnigan 2007,
Boundary-Layer Meteorol. 123:339). A drop in that well-mixed layer leaves it either through the top at ``w_e`` or
through the bottom at its fall speed ``v_t``, competing first-order losses: the share ``w_e / (w_e + v_t)`` rises
out of the canopy and the surface layer carries it from the canopy's top (fine drops, whose ``v_t`` is comparable
with ``w_e``, make the far tail of the drift curve), the rest settles among the plants. All landing bands share the
same log-distance bins, so the three releases (above the crop, exchanged, settled in it) add up bin by bin.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from vinecli.spray.surface_layer import SurfaceLayer, landing_bands

__all__ = ["BEYOND_M", "SQRT_STK50", "impaction_share", "lifted_parcels"]

SQRT_STK50 = 0.49  # Marple & Willeke 1976, round jets
_WIDTH = 0.1 / np.log(9.0)  # logistic scale: 10 % -> 90 % over ±0.1 in √Stk
#: where the share still airborne at the far-field model's reach is put (far beyond any drift domain), m downwind
BEYOND_M = 1.0e4
#: a bin's parcel spreads over a disc this many times the bin's half width: neighbouring bins overlap, so the
#: deposit is smooth across bin edges (ripple about ±9 %; 1 would leave it falling to 0 between bins)
BAND_SMOOTHING = 4.0
#: the wind inside a canopy falls as exp(-a (1 - z/h)) below its top h (Cionco 1965, J. Appl. Meteorol. 4:517; a ≈ 2
#: for moderately dense crops): the drops released among the hedges are carried by that slower wind
CANOPY_ATTENUATION = 2.0
#: u*/U_h at the top of a dense canopy (Raupach et al. 1996; Harman & Finnigan 2007): the canopy air's transfer
#: velocity to the surface layer is β u*
CANOPY_BETA = 0.3
#: how far downwind the far-field model follows the drops, m (beyond: airborne out of the drift domain)
REACH_M = 250.0


def impaction_share(d_m: np.ndarray, jet_speed_mps: np.ndarray, jet_diam_m: float, rho_w: float = 998.2,
                    mu: float = 1.81e-5) -> np.ndarray:
    """Share of the drops (diameter m) the wake (speed m/s, diameter m) drives into the ground, 0..1."""
    stk = rho_w * np.asarray(d_m) ** 2 * np.maximum(np.asarray(jet_speed_mps, dtype=np.float64), 0.0) / (
        9.0 * mu * jet_diam_m)
    return 1.0 / (1.0 + np.exp(-(np.sqrt(stk) - SQRT_STK50) / _WIDTH))


# parameters: the formula's inputs (module doc): arrays of the lifted parcels, one value per parcel each, and the
# surface layer's (roughness, stability, the crop's displacement)
def lifted_parcels(x: np.ndarray, y: np.ndarray, lifted_l: np.ndarray, v_t: np.ndarray, t_fall: np.ndarray,
                   wind_x: np.ndarray, wind_y: np.ndarray, z_wind_m: np.ndarray, roughness_m: float,
                   jet_diam_m: float | np.ndarray, obukhov_m: float = math.inf,
                   offset_m: float | np.ndarray | None = None, displacement_m: float = 0.0,
                   spread_m: float | np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The parcels the outwash re-releases (see the module doc), one per lifted parcel and landing band.

    Inputs per lifted parcel: landing point (m ENU), lifted volume (L), terminal velocities (m/s, (n, 2): the
    lowest and highest of its size class), fall time so far (s), wind (m/s ENU) at height ``z_wind_m`` (m above
    the ground), the release layer's top (m: the wall jet's ``W``, or per parcel), where the layer starts downwind
    of the landing point (m, per parcel; default half the top: the wall jet's ``W/2``), the crop's zero-plane
    displacement (m: the share released below it stays among the plants, the rest rises into the surface layer
    above them), the least radius each landing bin spreads over (m, per parcel; default the offset). Returns ``x, y,
    vol, t_fall,
    vx, vy, vz, radius, src`` (src: index of the parcel it came from; radius: the disc each bin spreads over, m: its
    smoothed width, at least the release's offset).
    """
    speed = np.hypot(wind_x, wind_y)
    top = np.broadcast_to(np.asarray(jet_diam_m, dtype=np.float64), x.shape)
    offset = 0.5 * top if offset_m is None else np.broadcast_to(np.asarray(offset_m, dtype=np.float64), x.shape)
    spread = offset if spread_m is None else np.broadcast_to(np.asarray(spread_m, dtype=np.float64), x.shape)
    ex = np.where(speed > 0, wind_x / np.maximum(speed, 1e-12), 0.0)
    ey = np.where(speed > 0, wind_y / np.maximum(speed, 1e-12), 0.0)
    cols: dict[str, list[np.ndarray]] = {k: [] for k in ("x", "y", "vol", "t_fall", "vx", "vy", "vz", "radius", "src")}
    d_plane = max(float(displacement_m), 0.0)
    still = speed <= 0.0
    if x.size and still.all():  # a calm run: every parcel lands where it was released, one bin each
        return _all_in_still_air(x, y, lifted_l, v_t, t_fall, wind_x, wind_y, top, offset, spread,
                                 (d_plane, roughness_m, obukhov_m))
    for i in range(x.size):
        if still[i]:  # still air carries nothing away: everything lands where it was released
            share, fall_s = _still_air(float(top[i]), float(v_t[i, 0]), float(v_t[i, 1]), d_plane, roughness_m,
                                       obukhov_m)
            d = offset[i] + np.zeros(1)
            _append(cols, i, (x[i] + ex[i] * d, y[i] + ey[i] * d, lifted_l[i] * np.array([share]),
                              t_fall[i] + np.array([fall_s]), wind_x[i], wind_y[i],
                              math.sqrt(v_t[i, 0] * v_t[i, 1]) + 0.0, np.array([spread[i]])))
            continue
        above = max(float(top[i]) - d_plane, 0.0)
        sheltered = 1.0 - above / max(float(top[i]), 1e-9)  # released evenly over [0, top]: the share below d
        vts = (float(v_t[i, 0]), float(v_t[i, 1]))
        layer = SurfaceLayer.from_wind(float(speed[i]), max(float(z_wind_m[i]) - d_plane, 2.0 * roughness_m),
                                       roughness_m, obukhov_m)
        parts: list[tuple[float, tuple[np.ndarray, ...]]] = []
        landing_layer = layer  # whose turbulence the drops come down through (the crop's own when all start in it)
        if above > 0.0:
            parts.append((1.0 - sheltered, landing_bands(layer, vts, above, REACH_M)))
        if sheltered > 0.0:  # the share released among the plants
            low = min(float(top[i]), d_plane)
            # the canopy air's exchange with the surface layer lifts a share out of the crop (module doc)
            w_e, vt_mid = CANOPY_BETA * layer.ustar, math.sqrt(vts[0] * vts[1])
            vent = w_e / (w_e + vt_mid) if w_e > 0.0 else 0.0
            if vent > 0.0:  # released from the canopy's top (d = 2/3 of it) after its time in the canopy's air
                m1, d1, h1, t1 = landing_bands(layer, vts, 0.5 * d_plane, REACH_M)
                parts.append((sheltered * vent, (m1, d1, h1, t1 + low / (w_e + vt_mid))))
            # the rest settles among the plants, carried by the slower wind inside the canopy
            slow = math.exp(-CANOPY_ATTENUATION * (1.0 - 0.5 * low / (1.5 * d_plane)))
            inner = SurfaceLayer.from_wind(slow * float(speed[i]), float(z_wind_m[i]), roughness_m, obukhov_m)
            parts.append((sheltered * (1.0 - vent), landing_bands(inner, vts, low, REACH_M)))
            landing_layer = layer if above > 0.0 else inner
        mass, dist, half, time = _add_bands(parts)
        d = offset[i] + np.where(np.isfinite(dist), dist, BEYOND_M)
        # the drops reach the ground at their fall speed plus the turbulence's vertical speed (their paths through
        # the hedges on the way down are that steep; the far field itself is the surface layer's, without hedges)
        sigma_w = float(landing_layer.sigma_w(np.zeros(1))[0])
        _append(cols, i, (x[i] + ex[i] * d, y[i] + ey[i] * d, lifted_l[i] * mass, t_fall[i] + time, wind_x[i],
                          wind_y[i], math.sqrt(v_t[i, 0] * v_t[i, 1]) + sigma_w,
                          np.maximum(BAND_SMOOTHING * half, spread[i])))  # at least the release's own spread
    return {k: np.concatenate(v) if v else np.zeros(0) for k, v in cols.items()}


def _append(cols: dict[str, list[np.ndarray]], i: int, bins: tuple) -> None:
    """Add parcel ``i``'s landing bins: (x, y, vol, t_fall arrays; vx, vy, vz per parcel; radius array)."""
    bx, by, vol, t_fall, vx, vy, vz, radius = bins
    n = vol.size
    for k, v in (("x", bx), ("y", by), ("vol", vol), ("t_fall", t_fall), ("radius", radius)):
        cols[k].append(v)
    for k, c in (("vx", vx), ("vy", vy), ("vz", vz), ("src", i)):
        cols[k].append(np.full(n, c))


@lru_cache(maxsize=4096)
def _still_air(top: float, vt_lo: float, vt_hi: float, d_plane: float, roughness_m: float,
               obukhov_m: float) -> tuple[float, float]:
    """(landed share, mean time s) of a parcel released evenly over [0, ``top``] m in still air: nothing carries it
    away, so it all lands where it was released (u* = 0: no exchange out of the canopy either)."""
    layer = SurfaceLayer(0.0, roughness_m, obukhov_m)
    above = max(top - d_plane, 0.0)
    sheltered = 1.0 - above / max(top, 1e-9)
    parts = []
    if above > 0.0:
        parts.append((1.0 - sheltered, landing_bands(layer, (vt_lo, vt_hi), above, REACH_M)))
    if sheltered > 0.0:
        parts.append((sheltered, landing_bands(layer, (vt_lo, vt_hi), min(top, d_plane), REACH_M)))
    mass = np.concatenate([w * b[0] for w, b in parts])
    time = float(np.dot(mass, np.concatenate([b[3] for _, b in parts]))) / max(float(mass.sum()), 1e-300)
    return float(mass.sum()), time


# parameters: the lifted parcels' arrays (as lifted_parcels takes them) and the surface layer's constants
def _all_in_still_air(x: np.ndarray, y: np.ndarray, lifted_l: np.ndarray, v_t: np.ndarray, t_fall: np.ndarray,
                      wind_x: np.ndarray, wind_y: np.ndarray, top: np.ndarray, offset: np.ndarray,
                      spread: np.ndarray, air: tuple[float, float, float]) -> dict[str, np.ndarray]:
    """:func:`lifted_parcels` when no parcel has wind: one bin per parcel where it was released (the same numbers
    as parcel by parcel, computed once per release layer and size class)."""
    keys, inv = np.unique(np.column_stack([top, v_t[:, 0], v_t[:, 1]]), axis=0, return_inverse=True)
    per_key = np.array([_still_air(float(t), float(lo), float(hi), *air) for t, lo, hi in keys]).reshape(-1, 2)
    share, fall_s = per_key[inv.ravel(), 0], per_key[inv.ravel(), 1]
    d = offset + 0.0
    return {"x": x + 0.0 * d, "y": y + 0.0 * d, "vol": lifted_l * share, "t_fall": t_fall + fall_s,
            "vx": np.array(wind_x, dtype=np.float64), "vy": np.array(wind_y, dtype=np.float64),
            "vz": np.sqrt(v_t[:, 0] * v_t[:, 1]) + 0.0, "radius": np.array(spread, dtype=np.float64),
            "src": np.arange(x.size)}


def _add_bands(parts: list[tuple[float, tuple[np.ndarray, ...]]]) -> tuple[np.ndarray, ...]:
    """Landing bands of several releases (weight, (mass, distance, half width, time)) added bin by bin: every
    release's bins are the same log-distance bins (:func:`~vinecli.spray.surface_layer.landing_bands`), so equal
    distances are one bin (its time the mass-weighted mean)."""
    if not parts:
        return (np.zeros(0),) * 4
    if len(parts) == 1:
        w, (m1, d1, h1, t1) = parts[0]
        return w * m1, d1, h1, t1
    mass = np.concatenate([w * b[0] for w, b in parts])
    dist = np.concatenate([b[1] for _, b in parts])
    half = np.concatenate([b[2] for _, b in parts])
    time = np.concatenate([b[3] for _, b in parts])
    key, first, inv = np.unique(dist, return_index=True, return_inverse=True)
    m = np.bincount(inv, weights=mass)
    t = np.bincount(inv, weights=mass * time) / np.maximum(m, 1e-300)
    return m, key, half[first], np.where(m > 0, t, time[first])
