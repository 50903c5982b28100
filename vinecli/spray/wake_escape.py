"""Drops a crosswind strips from the rotor wake's edge before they reach the ground. SI units, metres.

The downwash drives the spray down only where the wake is. The wake's edge lies ``r_e`` from the vehicle's
axis: the rotors' contracted wakes at the ends of the arms, ``r_e = arm + R/√2`` (momentum theory's far-wake
radius of each rotor). A size class lands on a disc of radius ``R_f`` (its ballistic reach and the wake's
spreading, :mod:`vinecli.spray.wake`) around its nozzle, moved by the drops' lag behind the air: they leave the
nozzle with the vehicle's velocity and relax to the air's with their relaxation time τ, so relative to the air the
wake was shed into they end ``(v - u) τ (1 - e^{-T/τ})`` towards the vehicle's motion through the air. In a
crosswind that is upwind: coarse drops leave a skewed wake on its upwind side.

**A moving vehicle's wake is a trail.** Behind a vehicle that moves more than its wake's radius during the fall
(``|v| T > r_e``), the wake is a band along the track, shed continuously: air moving along the track carries drops
along the band, not out of it. Only the share of the disc beyond the band's half width ``r_e`` across the track is
outside (semicircle law), and only the air's motion across the track (the crosswind relative to the vehicle) can
carry it away. A hovering vehicle's wake is a round column (exact overlap of two discs) that any airspeed crosses.
Between the two the weight of the column is ``β = 1 / (1 + (|v| T / r_e)²)``, and the crossflow is
``c = sqrt(a_⊥² + (β a_∥)²)`` of the air's velocity relative to the vehicle across and along the track.

What lies outside the wake fell through air the downwash did not drive:

* **still air entrains it back**: a round jet draws the surrounding air in at ``α w`` (entrainment coefficient
  α = 0.057 of round jets, Fischer et al. 1979, *Mixing in Inland and Coastal Waters*, §9.1; w the wake's
  downward speed half way down);
* **a crossflow** ``c`` **sweeps it away**: the share stripped is ``outside × c / (c + α w)``;
* **inertia**: a drop leaving the wake still moves down at the wake's speed and loses it over ``τ w``; it is freed
  only if that is short beside the half of the fall still ahead, weight ``exp(-τ w / (h/2))`` (coarse drops hit
  the ground or the canopy as if still in the wake).

The stripped drops leave the wake anywhere along the fall: the surface layer (:mod:`vinecli.spray.surface_layer`)
carries them from a release layer between the ground and the nozzles' height, from the wake's edge downwind.
"""

from __future__ import annotations

import math

import numpy as np

from vinecli.spray.interception import semicircle_cdf

__all__ = ["ENTRAINMENT", "disc_outside_share", "stripped_share", "wake_edge_radius_m"]

ENTRAINMENT = 0.057  # round jet's entrainment coefficient (Fischer et al. 1979, §9.1)


def wake_edge_radius_m(arm_m: float, rotor_radius_m: float) -> float:
    """Radius of the vehicle's wake (m): the rotor hubs' distance from the axis plus a rotor's far-wake radius."""
    return max(arm_m, 0.0) + rotor_radius_m / math.sqrt(2.0)


def disc_outside_share(radius: np.ndarray, offset: np.ndarray, edge: float) -> np.ndarray:
    """Share of a uniform disc (radius m, centre ``offset`` m from the wake's axis) beyond the circle ``edge`` m."""
    a = np.maximum(np.asarray(radius, dtype=np.float64), 1e-9)
    d = np.maximum(np.abs(np.asarray(offset, dtype=np.float64)), 1e-12)
    b = float(edge)
    # area of the lens where the disc (a) and the wake's circle (b) overlap, centres d apart
    c1 = np.clip((d * d + a * a - b * b) / (2.0 * d * a), -1.0, 1.0)
    c2 = np.clip((d * d + b * b - a * a) / (2.0 * d * b), -1.0, 1.0)
    k = (-d + a + b) * (d + a - b) * (d - a + b) * (d + a + b)
    lens = a * a * np.arccos(c1) + b * b * np.arccos(c2) - 0.5 * np.sqrt(np.maximum(k, 0.0))
    inside = np.where(d >= a + b, 0.0, np.where(d <= np.abs(a - b), np.pi * np.minimum(a, b) ** 2, lens))
    return np.clip(1.0 - inside / (np.pi * a * a), 0.0, 1.0)


def band_outside_share(radius: np.ndarray, offset: np.ndarray, edge: float) -> np.ndarray:
    """Share of a uniform disc (radius m, centre ``offset`` m across the track) beyond the band ``|s| <= edge``."""
    r = np.maximum(np.asarray(radius, dtype=np.float64), 1e-9)
    d = np.asarray(offset, dtype=np.float64)
    return np.clip(1.0 - (semicircle_cdf((edge - d) / r) - semicircle_cdf((-edge - d) / r)), 0.0, 1.0)


# parameters: the formula's inputs (module doc), arrays broadcast together
def stripped_share(radius: np.ndarray, offset_xy: tuple[np.ndarray, np.ndarray], air_xy: tuple[np.ndarray, np.ndarray],
                   velocity_xy: tuple[np.ndarray, np.ndarray], fall_s: np.ndarray, edge: float, wake_mps: np.ndarray,
                   tau_s: np.ndarray, fall_m: np.ndarray) -> np.ndarray:
    """Share of a class the crossflow strips from the wake (module doc). Arrays broadcast together: the class's
    disc radius (m) and its centre relative to the wake's axis (m ENU, nozzle + lag), the air's velocity relative to
    the vehicle (m/s ENU), the vehicle's velocity (m/s ENU), the fall time (s), the wake's radius ``edge`` (m), its
    downward speed half way down (m/s), the relaxation time (s), the fall height (m)."""
    vx, vy = (np.asarray(a, dtype=np.float64) for a in velocity_xy)
    speed = np.hypot(vx, vy)
    tx = np.where(speed > 1e-6, vx / np.maximum(speed, 1e-6), 1.0)
    ty = np.where(speed > 1e-6, vy / np.maximum(speed, 1e-6), 0.0)
    ox, oy = offset_xy
    ax, ay = air_xy
    column = 1.0 / (1.0 + (speed * np.asarray(fall_s) / edge) ** 2)  # weight of the round column against the trail
    across = ox * -ty + oy * tx
    outside = column * disc_outside_share(radius, np.hypot(ox, oy), edge) + (1.0 - column) * band_outside_share(
        radius, across, edge)
    a_along = ax * tx + ay * ty
    a_across = ax * -ty + ay * tx
    cross = np.hypot(a_across, column * a_along)
    w = np.maximum(np.asarray(wake_mps, dtype=np.float64), 0.0)
    swept = cross / np.maximum(cross + ENTRAINMENT * w, 1e-9)
    freed = np.exp(-np.asarray(tau_s) * w / np.maximum(0.5 * np.asarray(fall_m, dtype=np.float64), 1e-3))
    return np.clip(outside * swept * freed, 0.0, 1.0)
