"""Sensor models: IMU, barometer, magnetometer, GNSS (Gazebo/PX4 SITL conventions).

Every sensor takes the ground truth (:class:`~vinecli.types.RigidState`: ENU position,
velocity and acceleration, FLU body rates, quaternion FLU -> ENU) and a seeded numpy
Generator, so a run is deterministic for a seed. Each one is rate-limited on the integer
microsecond clock: a sample is due when ``t_us // period_us`` has advanced (first sample at
t = 0); otherwise ``sample`` returns None. Outputs are in the sensor frame, which is body
FLU unless the spec's ``mount.rpy_deg`` rotates it.

* IMU: specific force ``f = R^T (a - g)`` (level at rest: (0, 0, +g)) and body rates, plus
  the lever arm of the mount offset r: ``ω × (ω × r) + α × r`` with α the finite difference
  of the body rates between IMU samples; white noise σ = density / √dt (= density × √rate),
  bias random walk ``b += rw √dt n``, then quantisation to the LSB.
* Barometer: ISA/Gazebo formula at ``origin_alt + z`` (:mod:`vinecli.flight.atmosphere`),
  random-walk drift + white noise (Pa), quantisation; altitude = pressure altitude.
* Magnetometer: WMM field at the origin (:mod:`vinecli.flight.magnetic`), rotated into the
  body, gauss, white noise.
* GNSS: antenna position ``p + R r`` (and velocity ``v + R (ω × r)``) with white noise per
  axis, converted by :meth:`GeoOrigin.enu_to_geodetic_fast`; eph/epv = the noise σ (≥ 1 cm).
"""

from __future__ import annotations

import math

import numpy as np

from vinecli.constants import STANDARD_GRAVITY
from vinecli.flight.atmosphere import altitude_at, pressure_at, temperature_at
from vinecli.flight.magnetic import earth_field_ned
from vinecli.frames import QuatXYZW, Vec3, ned_to_enu, quat_from_euler, quat_rotate, quat_rotate_inv, true_enu_to_grid
from vinecli.geo import GeoOrigin
from vinecli.specs.vehicle import BaroSpec, GnssSpec, ImuSpec, MagSpec, MountSpec, SensorsSpec
from vinecli.types import BaroSample, GnssSample, ImuSample, MagSample, RigidState

__all__ = ["Baro", "Gnss", "Imu", "Mag", "SensorSuite", "make_sensors"]

G0 = STANDARD_GRAVITY


class _Normals:
    """Standard normal draws from a Generator, fetched in blocks (one numpy call per block)."""

    def __init__(self, rng: np.random.Generator, block: int = 4096) -> None:
        self.rng = rng
        self.block = block
        self.buf: list[float] = []
        self.i = 0

    def take(self, n: int) -> list[float]:
        if self.i + n > len(self.buf):
            self.buf = self.rng.standard_normal(max(self.block, n)).tolist()
            self.i = 0
        i = self.i
        self.i = i + n
        return self.buf[i : i + n]


class _Rate:
    """Integer-µs rate limiter on the grid k * period_us."""

    def __init__(self, rate_hz: float) -> None:
        self.period_us = max(1, round(1e6 / rate_hz))
        self.last_k = -1
        self.last_t_us: int | None = None

    def due(self, t_us: int) -> float | None:
        """Elapsed time (s) since the previous sample if one is due now, else None."""
        k = t_us // self.period_us
        if k <= self.last_k:
            return None
        self.last_k = k
        last = self.last_t_us
        self.last_t_us = t_us
        if last is None or t_us <= last:
            return self.period_us * 1e-6
        return (t_us - last) * 1e-6


def _mount_quat(mount: MountSpec) -> QuatXYZW | None:
    r, p, y = mount.rpy_deg
    if r == 0.0 and p == 0.0 and y == 0.0:
        return None
    return quat_from_euler(math.radians(r), math.radians(p), math.radians(y))


def _quantize(x: float, q: float) -> float:
    return round(x / q) * q if q > 0.0 else x


class Imu:
    """Accelerometer + gyroscope (specific force m/s², rates rad/s; sensor frame = FLU by default)."""

    def __init__(self, spec: ImuSpec, rng: np.random.Generator, *, g: float = G0) -> None:
        self.spec = spec
        self.g = float(g)
        self._rate = _Rate(spec.rate_hz)
        self._n = _Normals(rng)
        self._r: Vec3 | None = None if spec.mount.position_m == (0.0, 0.0, 0.0) else tuple(spec.mount.position_m)  # type: ignore[assignment]
        self._qm = _mount_quat(spec.mount)
        self.accel_bias: list[float] = [0.0, 0.0, 0.0]
        self.gyro_bias: list[float] = [0.0, 0.0, 0.0]
        self._w_prev: Vec3 | None = None
        self._walk = spec.accel_bias_random_walk > 0.0 or spec.gyro_bias_random_walk > 0.0
        # the spec's numbers as plain floats (read every step)
        self._accel_walk, self._gyro_walk = spec.accel_bias_random_walk, spec.gyro_bias_random_walk
        self._accel_density, self._gyro_density = spec.accel_noise_density, spec.gyro_noise_density
        self._accel_q, self._gyro_q = spec.accel_quantization, spec.gyro_quantization
        self.last: ImuSample | None = None

    def sample(self, truth: RigidState) -> ImuSample | None:
        """New IMU sample at ``truth.t_us`` or None when not due."""
        dt = self._rate.due(truth.t_us)
        if dt is None:
            return None
        ax, ay, az = truth.acc
        fx, fy, fz = quat_rotate_inv(truth.quat, (ax, ay, az + self.g))
        wx, wy, wz = truth.omega_body
        if self._r is not None:
            rx, ry, rz = self._r
            # centripetal ω × (ω × r)
            cx, cy, cz = wy * rz - wz * ry, wz * rx - wx * rz, wx * ry - wy * rx
            fx += wy * cz - wz * cy
            fy += wz * cx - wx * cz
            fz += wx * cy - wy * cx
            if self._w_prev is not None:
                px, py, pz = self._w_prev
                bx, by, bz = (wx - px) / dt, (wy - py) / dt, (wz - pz) / dt
                fx += by * rz - bz * ry
                fy += bz * rx - bx * rz
                fz += bx * ry - by * rx
            self._w_prev = (wx, wy, wz)
        if self._qm is not None:
            fx, fy, fz = quat_rotate_inv(self._qm, (fx, fy, fz))
            wx, wy, wz = quat_rotate_inv(self._qm, (wx, wy, wz))
        nz = self._n
        if nz.i + 12 > len(nz.buf):
            nz.buf = nz.rng.standard_normal(nz.block).tolist()
            nz.i = 0
        n, j = nz.buf, nz.i
        nz.i = j + 12
        sq = math.sqrt(dt)
        ab, gb = self.accel_bias, self.gyro_bias
        if self._walk:
            kab, kgb = self._accel_walk * sq, self._gyro_walk * sq
            ab[0] += kab * n[j + 6]
            ab[1] += kab * n[j + 7]
            ab[2] += kab * n[j + 8]
            gb[0] += kgb * n[j + 9]
            gb[1] += kgb * n[j + 10]
            gb[2] += kgb * n[j + 11]
        sa = self._accel_density / sq
        sg = self._gyro_density / sq
        acc = (fx + ab[0] + sa * n[j], fy + ab[1] + sa * n[j + 1], fz + ab[2] + sa * n[j + 2])
        gyr = (wx + gb[0] + sg * n[j + 3], wy + gb[1] + sg * n[j + 4], wz + gb[2] + sg * n[j + 5])
        qa, qg = self._accel_q, self._gyro_q
        if qa > 0.0:
            acc = (_quantize(acc[0], qa), _quantize(acc[1], qa), _quantize(acc[2], qa))
        if qg > 0.0:
            gyr = (_quantize(gyr[0], qg), _quantize(gyr[1], qg), _quantize(gyr[2], qg))
        out = ImuSample(truth.t_us, acc, gyr)
        self.last = out
        return out


class Baro:
    """Barometer: static pressure (Pa), temperature (°C) and pressure altitude (m AMSL)."""

    def __init__(self, spec: BaroSpec, origin_alt: float, rng: np.random.Generator) -> None:
        self.spec = spec
        self.origin_alt = float(origin_alt)
        self._rate = _Rate(spec.rate_hz)
        self._n = _Normals(rng)
        self.drift_pa = 0.0
        self._drift, self._noise, self._q = spec.drift_pa_per_sqrt_s, spec.noise_pa, spec.quantization_pa

    def sample(self, truth: RigidState) -> BaroSample | None:
        """New barometer sample or None when not due."""
        dt = self._rate.due(truth.t_us)
        if dt is None:
            return None
        h = self.origin_alt + truth.pos[2]
        n = self._n.take(2)
        self.drift_pa += self._drift * math.sqrt(dt) * n[1]
        p = _quantize(pressure_at(h) + self.drift_pa + self._noise * n[0], self._q)
        return BaroSample(truth.t_us, p, temperature_at(h) - 273.15, altitude_at(p))


class Mag:
    """Magnetometer: WMM field at the origin in the sensor frame (FLU by default), gauss."""

    def __init__(
        self, spec: MagSpec, origin: GeoOrigin, rng: np.random.Generator, *, year: float | None = None
    ) -> None:
        self.spec = spec
        self.field_ned: Vec3 = earth_field_ned(origin, year)  # true north
        self.field_enu: Vec3 = true_enu_to_grid(ned_to_enu(self.field_ned), origin.convergence_rad)  # the world's
        self._rate = _Rate(spec.rate_hz)
        self._n = _Normals(rng)
        self._qm = _mount_quat(spec.mount)
        self._noise = spec.noise_gauss

    def sample(self, truth: RigidState) -> MagSample | None:
        """New magnetometer sample or None when not due."""
        if self._rate.due(truth.t_us) is None:
            return None
        b = quat_rotate_inv(truth.quat, self.field_enu)
        if self._qm is not None:
            b = quat_rotate_inv(self._qm, b)
        n = self._n.take(3)
        s = self._noise
        return MagSample(truth.t_us, (b[0] + s * n[0], b[1] + s * n[1], b[2] + s * n[2]))


class Gnss:
    """GNSS receiver: lat/lon (deg), alt (m AMSL), ENU velocity, with white noise."""

    def __init__(self, spec: GnssSpec, origin: GeoOrigin, rng: np.random.Generator) -> None:
        self.spec = spec
        self.origin = origin
        self._rate = _Rate(spec.rate_hz)
        self._n = _Normals(rng)
        p = spec.mount.position_m
        self._r: Vec3 | None = None if p == (0.0, 0.0, 0.0) else tuple(p)  # type: ignore[assignment]
        self.eph_m = max(spec.horizontal_noise_m, 0.01)
        self.epv_m = max(spec.vertical_noise_m, 0.01)

    def sample(self, truth: RigidState) -> GnssSample | None:
        """New GNSS fix or None when not due."""
        if self._rate.due(truth.t_us) is None:
            return None
        s = self.spec
        px, py, pz = truth.pos
        vx, vy, vz = truth.vel
        if self._r is not None:
            rx, ry, rz = self._r
            ox, oy, oz = quat_rotate(truth.quat, (rx, ry, rz))
            px, py, pz = px + ox, py + oy, pz + oz
            wx, wy, wz = truth.omega_body
            ux, uy, uz = quat_rotate(truth.quat, (wy * rz - wz * ry, wz * rx - wx * rz, wx * ry - wy * rx))
            vx, vy, vz = vx + ux, vy + uy, vz + uz
        n = self._n.take(6)
        sh, sv, sw = s.horizontal_noise_m, s.vertical_noise_m, s.velocity_noise_mps
        lat, lon, alt = self.origin.enu_to_geodetic_fast(px + sh * n[0], py + sh * n[1], pz + sv * n[2])
        return GnssSample(
            truth.t_us,
            lat,
            lon,
            alt,
            (vx + sw * n[3], vy + sw * n[4], vz + sw * n[5]),
            fix_type=3,
            satellites=s.satellites,
            eph_m=self.eph_m,
            epv_m=self.epv_m,
        )


class SensorSuite:
    """All sensors of a vehicle; :meth:`sample_all` is called once per physics step."""

    def __init__(self, imu: Imu, baro: Baro, mag: Mag, gnss: Gnss) -> None:
        self.imu, self.baro, self.mag, self.gnss = imu, baro, mag, gnss

    def sample_all(self, truth: RigidState) -> tuple[ImuSample, BaroSample | None, MagSample | None, GnssSample | None]:
        """(imu, baro, mag, gnss) at ``truth.t_us``; the IMU sample is held when not due (never None)."""
        imu = self.imu.sample(truth)
        if imu is None:
            imu = self.imu.last
            if imu is None:  # only before the first due sample, which is at t = 0
                imu = ImuSample(truth.t_us, (0.0, 0.0, self.imu.g), (0.0, 0.0, 0.0))
        return imu, self.baro.sample(truth), self.mag.sample(truth), self.gnss.sample(truth)


def make_sensors(
    sensors: SensorsSpec, origin: GeoOrigin, seed: int, *, g: float = G0, year: float | None = None
) -> SensorSuite:
    """Build the IMU, barometer, magnetometer and GNSS with independent noise streams from ``seed``."""
    ss = np.random.SeedSequence(seed % (1 << 64))
    r_imu, r_baro, r_mag, r_gnss = (np.random.default_rng(c) for c in ss.spawn(4))
    return SensorSuite(
        Imu(sensors.imu, r_imu, g=g),
        Baro(sensors.baro, origin.alt, r_baro),
        Mag(sensors.mag, origin, r_mag, year=year),
        Gnss(sensors.gnss, origin, r_gnss),
    )
