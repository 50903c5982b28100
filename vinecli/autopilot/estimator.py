"""State estimator of the built-in autopilot, from the simulated sensors only.

* Attitude: Mahony complementary filter (gyro integration, accelerometer tilt correction
  against gravity plus the GNSS-derived acceleration, magnetometer heading correction,
  integral gyro-bias estimate from both). Quaternion (x, y, z, w)
  body FLU -> world ENU.
* Position/velocity: per axis a linear Kalman filter on (position, velocity, accelerometer
  bias), propagated every step with the IMU specific force rotated to ENU minus gravity,
  corrected by GNSS position + velocity (east, north), barometric altitude and GNSS vertical
  velocity (up). The gains are the periodic steady-state Kalman gains for each sensor's rate
  and noise (computed once at construction), so a step costs a few float operations.

GNSS latitude/longitude become ENU with the origin's local-tangent scale; barometric
altitude AMSL becomes ENU up as ``alt - origin.alt``. SI units throughout.
"""

from __future__ import annotations

import functools
import logging
import math
from typing import Any

from vinecli.autopilot.estimate import StateEstimate
from vinecli.constants import STANDARD_GRAVITY
from vinecli.frames import BodyFrame, QuatXYZW, Vec3, ned_to_enu, quat_from_euler, true_enu_to_grid
from vinecli.geo import GeoOrigin
from vinecli.specs.vehicle import VehicleSpec
from vinecli.types import BaroSample, GnssSample, MagSample, Observation

log = logging.getLogger(__name__)
G = STANDARD_GRAVITY


def earth_field_enu(origin: GeoOrigin) -> Vec3:
    """Earth magnetic field at the origin in the world frame (ENU along its grid), gauss (the WMM the simulated
    magnetometer uses)."""
    from vinecli.flight.magnetic import earth_field_ned

    return true_enu_to_grid(ned_to_enu(earth_field_ned(origin)), origin.convergence_rad)


def periodic_gains(dt: float, acc_psd: float, bias_psd: float,
                   sensors: list[tuple[float, tuple[tuple[float, float, float], ...], tuple[float, ...]]],
                   horizon_s: float = 30.0) -> list[tuple[tuple[float, ...], ...]]:
    """Cached :func:`_periodic_gains` (a batch worker builds the same estimator for every case)."""
    key = tuple((float(r), tuple(tuple(map(float, h)) for h in hs), tuple(map(float, v))) for r, hs, v in sensors)
    return list(_periodic_gains(float(dt), float(acc_psd), float(bias_psd), key, float(horizon_s)))


def discrete_model(dt: float, acc_psd: float, bias_psd: float) -> tuple[Any, Any]:
    """(F, Q) of state (p, v, b) over ``dt`` s: p' = v, v' = a_meas - b + w_a, b' = w_b, with white-noise
    densities ``acc_psd`` (m²/s³) and ``bias_psd`` (m²/s⁵).

    Exact, in closed form: the system matrix is nilpotent (A³ = 0), so F = exp(A dt) and the Van Loan
    integral Q = ∫ exp(A s) G exp(Aᵀ s) ds are polynomials in ``dt`` (no matrix exponential, and no scipy
    import on a run's start-up).
    """
    import numpy as np

    qa, qb = acc_psd, bias_psd
    d2, d3 = dt * dt, dt * dt * dt
    f = np.array([[1.0, dt, -0.5 * d2], [0.0, 1.0, -dt], [0.0, 0.0, 1.0]])
    q = np.array([[qa * d3 / 3.0 + qb * d3 * d2 / 20.0, qa * d2 / 2.0 + qb * d2 * d2 / 8.0, -qb * d3 / 6.0],
                  [qa * d2 / 2.0 + qb * d2 * d2 / 8.0, qa * dt + qb * d3 / 3.0, -qb * d2 / 2.0],
                  [-qb * d3 / 6.0, -qb * d2 / 2.0, qb * dt]])
    return f, q


@functools.lru_cache(maxsize=64)
def _periodic_gains(dt: float, acc_psd: float, bias_psd: float,
                    sensors: tuple[tuple[float, tuple[tuple[float, ...], ...], tuple[float, ...]], ...],
                    horizon_s: float) -> tuple[tuple[tuple[float, ...], ...], ...]:
    """Kalman gains (3 x m each) of state (p, v, b) with ``a = a_meas - b``, predicted every ``dt``
    s and corrected by each of ``sensors`` = [(rate_hz, H rows, measurement variances)], once the
    covariance has reached its periodic steady state (run offline over ``horizon_s``).

    ``acc_psd`` (m²/s³) and ``bias_psd`` (m²/s⁵) are the continuous process-noise densities.
    """
    import numpy as np

    f, q = discrete_model(dt, acc_psd, bias_psd)
    p = np.diag([100.0, 10.0, 1.0])
    every = [max(1, round(1.0 / (rate * dt))) for rate, _, _ in sensors]
    hs = [np.array(h, dtype=float) for _, h, _ in sensors]
    rs = [np.diag(r) for _, _, r in sensors]
    gains: list[np.ndarray] = [np.zeros((3, len(r))) for _, _, r in sensors]
    # one period of the correction pattern (lcm of the sensor intervals) as segments "m predictions,
    # then these corrections": m predictions at once are F^m P F^mT + Q_m, Q_m = sum F^i Q F^iT
    period = math.lcm(*every)
    segments: list[tuple[np.ndarray, np.ndarray, list[int]]] = []
    powers = {0: (np.eye(3), np.zeros((3, 3)))}
    m = 0
    for k in range(1, period + 1):
        m += 1
        if m not in powers:
            fp, qp = powers[m - 1]
            powers[m] = (f @ fp, f @ qp @ f.T + q)
        due = [j for j, n in enumerate(every) if k % n == 0]
        if due:
            segments.append((*powers[m], due))
            m = 0
    for _ in range(max(1, int(horizon_s / dt) // period)):
        p_start = p
        for fm, qm, due in segments:
            p = fm @ p @ fm.T + qm
            for j in due:
                h, r = hs[j], rs[j]
                kg = p @ h.T @ np.linalg.inv(h @ p @ h.T + r)
                p = (np.eye(3) - kg @ h) @ p
                p = 0.5 * (p + p.T)
                gains[j] = kg
        if np.max(np.abs(p - p_start)) <= 1e-14 * float(np.max(np.abs(p))):
            break  # periodic steady state reached
    return tuple(tuple(tuple(float(x) for x in row) for row in g) for g in gains)


#: PX4 EKF2_REQ_NSATS, EKF2_REQ_EPH (m), EKF2_REQ_EPV (m): GNSS quality needed before the filter is ready
GNSS_MIN_SATS = 6
GNSS_MAX_EPH_M = 3.0
GNSS_MAX_EPV_M = 5.0


def gnss_quality_problem(fix_type: int, satellites: int, eph_m: float, epv_m: float) -> str:
    """'' when a GNSS sample passes the EKF2-style quality checks, else what fails (with the value)."""
    if fix_type < 3:
        return f"GNSS fix type {fix_type} < 3"
    if satellites < GNSS_MIN_SATS:
        return f"GNSS {satellites} satellites < {GNSS_MIN_SATS}"
    if not eph_m <= GNSS_MAX_EPH_M:
        return f"GNSS eph {eph_m:.2f} m > {GNSS_MAX_EPH_M:g} m"
    if not epv_m <= GNSS_MAX_EPV_M:
        return f"GNSS epv {epv_m:.2f} m > {GNSS_MAX_EPV_M:g} m"
    return ""


class Estimator(StateEstimate):
    """Attitude, position and velocity from IMU, baro, mag and GNSS; see the module docstring.

    After :meth:`update`: ``pos`` (m, ENU), ``vel`` (m/s, ENU), ``quat`` (x, y, z, w),
    ``omega`` (bias-corrected gyro, rad/s, FLU), ``acc`` (m/s², ENU, gravity removed),
    ``ready`` (GNSS and baro fused for ``settle_s`` while the GNSS passes the PX4 EKF2 quality
    checks: 3-D fix, at least ``GNSS_MIN_SATS`` satellites, eph <= ``GNSS_MAX_EPH_M``, epv <=
    ``GNSS_MAX_EPV_M``); ``not_ready_reason`` says what it is waiting for; ``sigma_h_m`` / ``sigma_v_m``
    the GNSS position noise σ (the fence margins' unit).
    """

    # parameters: keyword-only filter gains and time constants with their defaults; a caller names the few it
    # changes
    def __init__(self, vehicle: VehicleSpec, origin: GeoOrigin, *, kp_acc: float = 0.4, ki_acc: float = 0.02,
                 kp_mag: float = 0.5, ki_mag: float = 0.01, acc_ref_tau_s: float = 0.5, acc_sigma: float = 0.2, bias_sigma: float = 0.02,
                 mag_field_enu: Vec3 | None = None, settle_s: float = 1.5) -> None:
        super().__init__()
        s = vehicle.sensors
        self.sigma_h_m = s.gnss.horizontal_noise_m
        self.sigma_v_m = s.gnss.vertical_noise_m
        self.origin = origin
        self.kp_acc = kp_acc
        self.ki_acc = ki_acc
        self.kp_mag = kp_mag
        self.ki_mag = ki_mag
        self.acc_ref_tau = acc_ref_tau_s
        self.settle_us = int(settle_s * 1e6)
        field = mag_field_enu if mag_field_enu is not None else earth_field_enu(origin)
        h = math.hypot(field[0], field[1])
        self.mag_ref_h = (field[0] / h, field[1] / h) if h > 0 else (0.0, 1.0)
        acc_psd = acc_sigma * acc_sigma
        bias_psd = bias_sigma * bias_sigma
        dt = 1.0 / s.imu.rate_hz
        g = s.gnss
        hp, hv = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
        var_p = max(g.horizontal_noise_m, 0.05) ** 2
        var_v = max(g.velocity_noise_mps, 0.02) ** 2
        (self.k_gnss,) = periodic_gains(dt, acc_psd, bias_psd, [(g.rate_hz, (hp, hv), (var_p, var_v))])
        baro_sigma_m = max(s.baro.noise_pa, 0.5) / 12.0  # ~12 Pa per metre near sea level
        self.k_baro, self.k_gnss_vz = periodic_gains(
            dt, acc_psd, bias_psd, [(s.baro.rate_hz, (hp,), (baro_sigma_m**2,)), (g.rate_hz, (hv,), (var_v,))])
        self.reset()

    def reset(self) -> None:
        """Forget everything (the next samples re-initialise the filter)."""
        self.quat: QuatXYZW = (0.0, 0.0, 0.0, 1.0)
        self.omega: Vec3 = (0.0, 0.0, 0.0)
        self.pos: Vec3 = (0.0, 0.0, 0.0)
        self.vel: Vec3 = (0.0, 0.0, 0.0)
        self.acc: Vec3 = (0.0, 0.0, 0.0)
        self.ready = False
        self.not_ready_reason = "waiting for GNSS and baro"
        self._gnss_quality_ok = False
        self._att_init = False
        self._gnss_init = False
        self._baro_init = False
        self._gyro_bias = [0.0, 0.0, 0.0]  # integral correction (= -bias)
        self._p = [0.0, 0.0, 0.0]
        self._v = [0.0, 0.0, 0.0]
        self._b = [0.0, 0.0, 0.0]
        self._t_us: int | None = None
        self._t_ready_us: int | None = None
        self._a_ref = [0.0, 0.0, 0.0]  # low-passed GNSS acceleration, ENU
        self._gnss_prev: tuple[int, Vec3] | None = None
        self._frame = BodyFrame()  # the attitude at the start of the step, as a matrix

    @property
    def gyro_bias(self) -> Vec3:
        """Estimated gyro bias, rad/s, body FLU (subtracted from the gyro)."""
        gb = self._gyro_bias
        return (-gb[0], -gb[1], -gb[2])

    # ------------------------------------------------------------------ attitude initialisation
    def _init_attitude(self, acc: Vec3, mag: Vec3 | None) -> None:
        ax, ay, az = acc
        roll = math.atan2(ay, az)
        pitch = math.atan2(-ax, math.hypot(ay, az))
        yaw = 0.0
        if mag is not None:
            # level the measured field with roll/pitch, compare its heading with the reference
            q_rp = quat_from_euler(roll, pitch, 0.0)
            x, y, z, w = q_rp
            mx, my, mz = mag
            # rotate body -> level frame
            tx = 2.0 * (y * mz - z * my)
            ty = 2.0 * (z * mx - x * mz)
            tz = 2.0 * (x * my - y * mx)
            lx = mx + w * tx + (y * tz - z * ty)
            ly = my + w * ty + (z * tx - x * tz)
            yaw = math.atan2(self.mag_ref_h[1], self.mag_ref_h[0]) - math.atan2(ly, lx)
        self.quat = quat_from_euler(roll, pitch, yaw)
        self._att_init = True

    # ------------------------------------------------------------------ per step
    def update(self, obs: Observation) -> None:
        """Fuse this step's samples (``obs.imu`` every step, others when not None)."""
        imu = obs.imu
        t = obs.t_us
        dt = 0.0 if self._t_us is None else (t - self._t_us) * 1e-6
        self._t_us = t
        fx, fy, fz = imu.accel_flu
        mag = obs.mag
        if not self._att_init:
            self._init_attitude(imu.accel_flu, mag.field_flu_gauss if mag is not None else None)
        frame = self._frame
        x, y, z, w = self.quat
        frame.set(x, y, z, w)
        self._fuse_attitude(fx, fy, fz, imu.gyro_flu, mag, dt)
        self._propagate(fx, fy, fz, dt)
        gn = obs.gnss
        if gn is not None:
            self._fuse_gnss(gn)
        ba = obs.baro
        if ba is not None:
            self._fuse_baro(ba)
        p, v = self._p, self._v
        self.pos = (p[0], p[1], p[2])
        self.vel = (v[0], v[1], v[2])
        if not self.ready and self._gnss_init and self._baro_init and self._gnss_quality_ok:
            if self._t_ready_us is None:
                self.not_ready_reason = "settling"
                self._t_ready_us = t
            elif t - self._t_ready_us >= self.settle_us:
                self.ready = True
                self.not_ready_reason = ""

    def _fuse_attitude(self, fx: float, fy: float, fz: float, gyro: Vec3, mag: MagSample | None, dt: float) -> None:
        """Complementary filter: the gyro (bias-corrected) integrated, corrected towards the accelerometer's
        gravity (minus the GNSS-derived acceleration) and the magnetometer's heading; the bias integral."""
        f = self._frame
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = f.r00, f.r01, f.r02, f.r10, f.r11, f.r12, f.r20, f.r21, f.r22
        x, y, z, w = self.quat
        gx, gy, gz = gyro
        gb = self._gyro_bias
        gx += gb[0]
        gy += gb[1]
        gz += gb[2]
        self.omega = (gx, gy, gz)
        ex = ey = ez = 0.0
        an = math.sqrt(fx * fx + fy * fy + fz * fz)
        ix = iy = iz = 0.0  # raw error for the bias integral
        if 0.5 * G < an < 1.5 * G:
            inv = 1.0 / an
            ax_, ay_, az_ = fx * inv, fy * inv, fz * inv
            # expected specific force: gravity + the GNSS-derived acceleration (world), in body
            ar = self._a_ref
            rfx, rfy, rfz = ar[0], ar[1], ar[2] + G
            rn = 1.0 / math.sqrt(rfx * rfx + rfy * rfy + rfz * rfz)
            rfx, rfy, rfz = rfx * rn, rfy * rn, rfz * rn
            vbx = r00 * rfx + r10 * rfy + r20 * rfz
            vby = r01 * rfx + r11 * rfy + r21 * rfz
            vbz = r02 * rfx + r12 * rfy + r22 * rfz
            # error = measured x estimated
            ix = ay_ * vbz - az_ * vby
            iy = az_ * vbx - ax_ * vbz
            iz = ax_ * vby - ay_ * vbx
            k = self.kp_acc
            ex, ey, ez = ix * k, iy * k, iz * k
            k = self.ki_acc
            ix, iy, iz = ix * k, iy * k, iz * k
        if mag is not None:
            mx, my, mz = mag.field_flu_gauss
            wx = r00 * mx + r01 * my + r02 * mz
            wy = r10 * mx + r11 * my + r12 * mz
            nh = math.sqrt(wx * wx + wy * wy)
            if nh > 1e-9:
                rx, ry = self.mag_ref_h
                # heading error about world z (measured -> reference), applied about world z in body
                e_up = (wx * ry - wy * rx) / nh
                k = e_up * self.kp_mag
                ex += k * r20
                ey += k * r21
                ez += k * r22
                k = e_up * self.ki_mag
                ix += k * r20
                iy += k * r21
                iz += k * r22
        if dt > 0.0:
            gb[0] += ix * dt
            gb[1] += iy * dt
            gb[2] += iz * dt
        if dt > 0.0:
            ox, oy, oz = gx + ex, gy + ey, gz + ez
            h = 0.5 * dt
            nx = x + h * (w * ox + y * oz - z * oy)
            ny = y + h * (w * oy - x * oz + z * ox)
            nz = z + h * (w * oz + x * oy - y * ox)
            nw = w - h * (x * ox + y * oy + z * oz)
            n = 1.0 / math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
            self.quat = (nx * n, ny * n, nz * n, nw * n)

    def _propagate(self, fx: float, fy: float, fz: float, dt: float) -> None:
        """Translation: the specific force (body FLU) rotated to the world, gravity and the estimated
        accelerometer bias removed, integrated into position and velocity over ``dt``."""
        f = self._frame
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = f.r00, f.r01, f.r02, f.r10, f.r11, f.r12, f.r20, f.r21, f.r22
        awx = r00 * fx + r01 * fy + r02 * fz
        awy = r10 * fx + r11 * fy + r12 * fz
        awz = r20 * fx + r21 * fy + r22 * fz - G
        p, v, b = self._p, self._v, self._b
        awx -= b[0]
        awy -= b[1]
        awz -= b[2]
        self.acc = (awx, awy, awz)
        if dt > 0.0:
            hd2 = 0.5 * dt * dt
            p[0] += v[0] * dt + awx * hd2
            p[1] += v[1] * dt + awy * hd2
            p[2] += v[2] * dt + awz * hd2
            v[0] += awx * dt
            v[1] += awy * dt
            v[2] += awz * dt

    def _fuse_gnss(self, gn: GnssSample) -> None:
        """A GNSS sample: quality gate while not ready, the low-passed GNSS acceleration, then position and
        velocity (horizontal) and vertical velocity fused with their fixed gains (the first sample initialises)."""
        p, v, b = self._p, self._v, self._b
        if not self.ready:
            problem = gnss_quality_problem(gn.fix_type, gn.satellites, gn.eph_m, gn.epv_m)
            self._gnss_quality_ok = not problem
            if problem:
                self.not_ready_reason = problem
                self._t_ready_us = None  # the settle time restarts once the quality is good
        gp = self._gnss_prev
        if gp is not None and gn.t_us > gp[0]:
            tg = (gn.t_us - gp[0]) * 1e-6
            al = tg / (self.acc_ref_tau + tg)
            ar = self._a_ref
            for i in (0, 1, 2):
                ar[i] += al * ((gn.vel_enu[i] - gp[1][i]) / tg - ar[i])
        self._gnss_prev = (gn.t_us, gn.vel_enu)
        e_m, n_m, _ = self.origin.geodetic_to_enu_fast(gn.lat_deg, gn.lon_deg, gn.alt_m)  # the world's frame
        gv = gn.vel_enu
        if not self._gnss_init:
            p[0], p[1] = e_m, n_m
            v[0], v[1] = gv[0], gv[1]
            self._gnss_init = True
            if not self._baro_init:
                p[2] = gn.alt_m - self.origin.alt
                v[2] = gv[2]
        else:
            kg = self.k_gnss
            for i, pm, vm in ((0, e_m, gv[0]), (1, n_m, gv[1])):
                rp = pm - p[i]
                rv = vm - v[i]
                p[i] += kg[0][0] * rp + kg[0][1] * rv
                v[i] += kg[1][0] * rp + kg[1][1] * rv
                b[i] += kg[2][0] * rp + kg[2][1] * rv
            kg = self.k_gnss_vz
            rv = gv[2] - v[2]
            p[2] += kg[0][0] * rv
            v[2] += kg[1][0] * rv
            b[2] += kg[2][0] * rv

    def _fuse_baro(self, ba: BaroSample) -> None:
        """A barometer sample: altitude fused with its fixed gains (the first sample initialises)."""
        p, v, b = self._p, self._v, self._b
        zm = ba.altitude_m - self.origin.alt
        if not self._baro_init:
            p[2] = zm
            self._baro_init = True
        else:
            kg = self.k_baro
            r = zm - p[2]
            p[2] += kg[0][0] * r
            v[2] += kg[1][0] * r
            b[2] += kg[2][0] * r
