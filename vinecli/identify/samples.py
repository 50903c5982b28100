"""The flight log on one time base, the motor outputs': what every fit regresses.

At each motor-output sample ``t_k`` (5-10 Hz in real logs): the outputs ``u`` (a snapshot), the IMU's
specific force and rates averaged over ``t_k ± h`` (``h`` half the median output interval; the 10 Hz
vertical acceleration of a real log is mostly vibration, the average is what the rotors produced over
that interval), the attitude (normalised linear interpolation), velocity (ENU and body FLU), height
above the take-off ground and the armed/landed state.

``airborne`` marks the samples a fit may use: armed, not landed, motors running, more than
:data:`MIN_HEIGHT_M` above the ground level (a land detector says "airborne" while the vehicle still sits
on its skids), :data:`EDGE_S` away from take-off and touch-down, tilt below :data:`MAX_TILT_DEG`, IMU
samples in the interval (no gap), and before an upset (a tilt beyond :data:`UPSET_TILT_DEG`: a log that
ends in a crash, e.g. a lost motor, is used up to :data:`UPSET_MARGIN_S` before it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vinecli.flightlog.flight_log import FlightLog
from vinecli.frames import quat_rotate_many

__all__ = ["FlightSamples", "interval_means", "make_samples", "quat_at"]

MIN_HEIGHT_M = 0.5
EDGE_S = 1.0
MAX_TILT_DEG = 45.0
UPSET_TILT_DEG = 60.0
UPSET_MARGIN_S = 1.0
#: steady hover: horizontal speed, vertical speed (m/s) and tilt (deg) below these
HOVER_LIMITS = (1.0, 0.3, 10.0)


@dataclass(frozen=True)
class FlightSamples:
    """Per motor-output sample (module docstring); frames ENU / FLU, SI units."""

    t_s: np.ndarray
    u: np.ndarray
    running: np.ndarray
    f_body: np.ndarray
    gyro_body: np.ndarray
    imu_count: np.ndarray
    quat: np.ndarray
    vel_enu: np.ndarray
    vel_body: np.ndarray
    height_m: np.ndarray
    tilt_deg: np.ndarray
    armed: np.ndarray
    landed: np.ndarray
    airborne: np.ndarray
    upset_t_s: float | None
    notes: tuple[str, ...]

    @property
    def speed(self) -> np.ndarray:
        """|velocity| m/s (the airspeed in still air)."""
        return np.linalg.norm(self.vel_enu, axis=1)

    def hover(self) -> np.ndarray:
        """Airborne samples in steady hover (:data:`HOVER_LIMITS`)."""
        vh, vz, tilt = HOVER_LIMITS
        return (self.airborne & (np.linalg.norm(self.vel_enu[:, :2], axis=1) < vh)
                & (np.abs(self.vel_enu[:, 2]) < vz) & (self.tilt_deg < tilt))

    def span(self) -> tuple[float, float]:
        """The flight the pack and the energy are judged over, s: first to last sample with the motors
        running, ending :data:`UPSET_MARGIN_S` before an upset."""
        run = np.flatnonzero(self.running)
        t1 = float(self.t_s[run[-1]])
        if self.upset_t_s is not None:
            t1 = min(t1, self.upset_t_s - UPSET_MARGIN_S)
        return float(self.t_s[run[0]]), t1

    def u_filled(self) -> np.ndarray:
        """``u`` with stopped motors (NaN) as 0."""
        return np.where(np.isfinite(self.u), self.u, 0.0)


def interval_means(t_src: np.ndarray, values: np.ndarray, t: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean of ``values`` (M, k) over samples with ``|t_src - t_i| <= h`` for each ``t_i``; (means, counts).
    Means are NaN where no sample falls in the interval (a gap)."""
    lo = np.searchsorted(t_src, t - h, side="left")
    hi = np.searchsorted(t_src, t + h, side="right")
    cs = np.vstack([np.zeros((1, values.shape[1])), np.cumsum(values, axis=0)])
    n = hi - lo
    with np.errstate(invalid="ignore", divide="ignore"):
        m = (cs[hi] - cs[lo]) / n[:, None]
    m[n == 0] = np.nan
    return m, n


def quat_at(t_src: np.ndarray, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Attitudes (x, y, z, w) at times ``t``: normalised linear interpolation with continuous signs."""
    q = np.array(q, dtype=float)
    flip = np.concatenate(([False], np.sum(q[1:] * q[:-1], axis=1) < 0.0))
    q[np.cumsum(flip) % 2 == 1] *= -1.0
    out = np.column_stack([np.interp(t, t_src, q[:, k]) for k in range(4)])
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def make_samples(log: FlightLog) -> FlightSamples:
    """Resample ``log`` onto its motor-output times and mark the usable airborne samples."""
    t = log.motors.t_s
    h = 0.5 * float(np.median(np.diff(t))) if len(t) > 1 else 0.05
    f, n = interval_means(log.imu.t_s, log.imu.accel_flu, t, h)
    gyro, _ = interval_means(log.imu.t_s, log.imu.gyro_flu, t, h)
    quat = quat_at(log.attitude.t_s, log.attitude.quat_xyzw, t)
    vel = np.column_stack([np.interp(t, log.position.t_s, log.position.vel_enu[:, k]) for k in range(3)])
    z = np.interp(t, log.position.t_s, log.position.pos_enu[:, 2])
    q_inv = quat * np.array([-1.0, -1.0, -1.0, 1.0])
    vel_body = quat_rotate_many(q_inv, vel)
    tilt = np.degrees(np.arccos(np.clip(1.0 - 2.0 * (quat[:, 0] ** 2 + quat[:, 1] ** 2), -1.0, 1.0)))
    armed, landed = log.state.at(t)
    running = armed & np.isfinite(log.motors.u).all(axis=1)
    notes: list[str] = []
    ground = float(np.median(z[landed])) if landed.any() else -math.inf
    if not landed.any():
        notes.append("the log never shows the vehicle landed: no height check against the ground")
    height = z - ground
    flying = armed & ~landed
    upset = np.flatnonzero(flying & (tilt > UPSET_TILT_DEG))
    upset_t = float(t[upset[0]]) if len(upset) else None
    air = flying & running & (height > MIN_HEIGHT_M) & (tilt < MAX_TILT_DEG) & (n > 0)
    for edge in t[np.flatnonzero(np.diff(flying.astype(np.int8)))]:
        air &= np.abs(t - edge) > EDGE_S
    if upset_t is not None:
        air &= t < upset_t - UPSET_MARGIN_S
        notes.append(f"upset at {upset_t:.1f} s (tilt {tilt[upset[0]]:.0f} deg, {t[-1] - upset_t:.1f} s before the log "
                     f"ends): samples from {upset_t - UPSET_MARGIN_S:.1f} s on are not used")
    gaps = [g for g in log.gaps if g[1] - g[0] > 0.0]
    for g0, g1 in gaps:
        air &= (t < g0 - h) | (t > g1 + h)
    if gaps:
        notes.append("gaps in the log (no motor or IMU samples): " + ", ".join(f"{a:.1f}-{b:.1f} s" for a, b in gaps))
    return FlightSamples(t_s=t, u=log.motors.u, running=running, f_body=f, gyro_body=gyro, imu_count=n, quat=quat,
                         vel_enu=vel, vel_body=vel_body, height_m=height, tilt_deg=tilt, armed=armed, landed=landed,
                         airborne=air, upset_t_s=upset_t, notes=tuple(notes))
