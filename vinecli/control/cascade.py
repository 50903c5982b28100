"""PX4-style multicopter cascade: position P -> velocity PID -> acceleration -> thrust vector
and attitude setpoint -> attitude P on quaternions -> body-rate PID -> allocation.

Frames: world ENU, body FLU, quaternions (x, y, z, w) body -> world, SI units. Everything
is plain floats (this runs in the 250 Hz loop); the position/velocity loop runs at
``ControlSpec.pos_loop_rate_hz`` (PX4 runs it at the estimator rate), the attitude and rate
loops every step.

* Position: ``v_sp = v_ff + K_p (p_sp - p)`` (plus an acceleration feed-forward ``a_ff``), limited to the vehicle's speed limits. An axis
  group (xy or z) can be driven by a velocity setpoint alone.
* Velocity: PID in acceleration units (PX4 ``MPC_*_VEL_*_ACC``). Vertical anti-windup:
  the integral stops when the collective thrust is at its limit in the error's direction;
  horizontal: tracking anti-windup on the part of the acceleration removed by the tilt /
  thrust limits (PX4 ``arw_gain = 2 / K_p``).
* Thrust vector ``F = m_est (a_sp + g z)``: the hover thrust feed-forward comes from the
  current mass estimate; vertical thrust has priority; tilt limited to ``MPC_TILTMAX``.
* Attitude: PX4 ``AttitudeControl`` (reduced attitude for the thrust direction, then yaw
  with weight ``MC_YAW_WEIGHT``), ``rate_sp = 2 K_att sign(q_e.w) q_e.xyz``.
* Rate: PID on body rates (one :class:`vinecli.control.pid.Pid` per axis) with derivative on
  the filtered gyro derivative, integral limited and frozen in the direction the mixer reports
  saturated; output normalised
  torques (see :mod:`vinecli.control.allocation` for the scale) -> N m -> mixer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vinecli.constants import STANDARD_GRAVITY
from vinecli.control.allocation import Mixer
from vinecli.control.pid import Pid
from vinecli.frames import QuatXYZW, Vec3
from vinecli.specs.vehicle import ControlSpec, VehicleSpec

G = STANDARD_GRAVITY


def thrust_to_attitude(fx: float, fy: float, fz: float, yaw: float) -> QuatXYZW:
    """Attitude (x, y, z, w) whose body z is along F (ENU) with heading ``yaw`` (rad from east, CCW).

    PX4 ``ControlMath::bodyzToAttitude`` in ENU/FLU.
    """
    n = math.sqrt(fx * fx + fy * fy + fz * fz)
    if n < 1e-9:
        zx, zy, zz = 0.0, 0.0, 1.0
    else:
        zx, zy, zz = fx / n, fy / n, fz / n
    cy, sy = -math.sin(yaw), math.cos(yaw)  # y_C = (-sin yaw, cos yaw, 0)
    # body_x = y_C x body_z
    xx = sy * zz
    xy = -cy * zz
    xz = cy * zy - sy * zx
    if zz < 0.0:
        xx, xy, xz = -xx, -xy, -xz
    nx = math.sqrt(xx * xx + xy * xy + xz * xz)
    if nx < 1e-9:
        xx, xy, xz = 1.0, 0.0, 0.0
    else:
        xx, xy, xz = xx / nx, xy / nx, xz / nx
    # body_y = body_z x body_x
    yx = zy * xz - zz * xy
    yy = zz * xx - zx * xz
    yz = zx * xy - zy * xx
    return matrix_columns_to_quat((xx, xy, xz), (yx, yy, yz), (zx, zy, zz))


def matrix_columns_to_quat(bx: Vec3, by: Vec3, bz: Vec3) -> QuatXYZW:
    """Quaternion (x, y, z, w), w >= 0, of the rotation matrix with columns bx, by, bz."""
    r00, r10, r20 = bx
    r01, r11, r21 = by
    r02, r12, r22 = bz
    tr = r00 + r11 + r22
    if tr > 0.0:
        s = math.sqrt(tr + 1.0) * 2.0
        q = ((r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s, 0.25 * s)
    elif r00 > r11 and r00 > r22:
        s = math.sqrt(1.0 + r00 - r11 - r22) * 2.0
        q = (0.25 * s, (r01 + r10) / s, (r02 + r20) / s, (r21 - r12) / s)
    elif r11 > r22:
        s = math.sqrt(1.0 + r11 - r00 - r22) * 2.0
        q = ((r01 + r10) / s, 0.25 * s, (r12 + r21) / s, (r02 - r20) / s)
    else:
        s = math.sqrt(1.0 + r22 - r00 - r11) * 2.0
        q = ((r02 + r20) / s, (r12 + r21) / s, 0.25 * s, (r10 - r01) / s)
    if q[3] < 0.0:
        return (-q[0], -q[1], -q[2], -q[3])
    return q


def attitude_rate_setpoint(q: QuatXYZW, qd: QuatXYZW, gain: Vec3, yaw_weight: float) -> Vec3:
    """Body-rate setpoint (rad/s, FLU) from attitude q to qd (both x, y, z, w, body -> world).

    PX4 ``AttitudeControl::update``; ``gain`` is (roll, pitch, yaw) P, the yaw gain is
    divided by the yaw weight as PX4's ``setProportionalGain`` does.
    """
    x, y, z, w = q
    dx, dy, dz, dw = qd
    # body z axes in world
    ezx = 2.0 * (x * z + w * y)
    ezy = 2.0 * (y * z - w * x)
    ezz = 1.0 - 2.0 * (x * x + y * y)
    edx = 2.0 * (dx * dz + dw * dy)
    edy = 2.0 * (dy * dz - dw * dx)
    edz = 1.0 - 2.0 * (dx * dx + dy * dy)
    # shortest rotation e_z -> e_zd (world frame)
    cx = ezy * edz - ezz * edy
    cy = ezz * edx - ezx * edz
    cz = ezx * edy - ezy * edx
    dt = ezx * edx + ezy * edy + ezz * edz
    if cx * cx + cy * cy + cz * cz < 1e-12 and dt < 0.0:
        # 180 deg: reduced attitude undefined, use the full attitude
        rx, ry, rz, rw = dx, dy, dz, dw
    else:
        rw0 = 1.0 + dt
        n = math.sqrt(rw0 * rw0 + cx * cx + cy * cy + cz * cz)
        ax, ay, az, aw = cx / n, cy / n, cz / n, rw0 / n
        # qd_red = q_rot (x) q
        rx = aw * x + ax * w + ay * z - az * y
        ry = aw * y - ax * z + ay * w + az * x
        rz = aw * z + ax * y - ay * x + az * w
        rw = aw * w - ax * x - ay * y - az * z
    if yaw_weight < 0.9999:
        # q_mix = qd_red^-1 (x) qd
        mx = rw * dx - rx * dw - ry * dz + rz * dy
        my = rw * dy + rx * dz - ry * dw - rz * dx
        mz = rw * dz - rx * dy + ry * dx - rz * dw
        mw = rw * dw + rx * dx + ry * dy + rz * dz
        if mw < 0.0:
            mx, my, mz, mw = -mx, -my, -mz, -mw
        mw = 1.0 if mw > 1.0 else (-1.0 if mw < -1.0 else mw)
        mz = 1.0 if mz > 1.0 else (-1.0 if mz < -1.0 else mz)
        # qd = qd_red (x) (0, 0, sin(w asin(mz)), cos(w acos(mw)))
        bz = math.sin(yaw_weight * math.asin(mz))
        bw = math.cos(yaw_weight * math.acos(mw))
        dx = rx * bw + ry * bz
        dy = ry * bw - rx * bz
        dz = rw * bz + rz * bw
        dw = rw * bw - rz * bz
    # q_e = q^-1 (x) qd
    ex = w * dx - x * dw - y * dz + z * dy
    ey = w * dy + x * dz - y * dw - z * dx
    ez = w * dz - x * dy + y * dx - z * dw
    ew = w * dw + x * dx + y * dy + z * dz
    s = 2.0 if ew >= 0.0 else -2.0
    yw = yaw_weight if yaw_weight > 1e-4 else 1.0
    return (s * ex * gain[0], s * ey * gain[1], s * ez * gain[2] / yw)


@dataclass(frozen=True)
class LoopGains:
    """The :class:`ControlSpec` numbers the position and attitude loops read at their rates, as plain
    floats (compiled, these are read without the pydantic attribute lookup). Units as the spec's."""

    pos_p_xy: float
    pos_p_z: float
    vel_p_xy: float
    vel_i_xy: float
    vel_d_xy: float
    vel_p_z: float
    vel_i_z: float
    vel_d_z: float
    vel_i_limit: float
    max_vel_xy: float
    max_vel_up: float
    max_vel_down: float
    att_p: Vec3
    yaw_weight: float

    @staticmethod
    def of(c: ControlSpec) -> LoopGains:
        """The spec's values, unchanged."""
        a = c.att_p
        return LoopGains(c.pos_p_xy, c.pos_p_z, c.vel_p_xy, c.vel_i_xy, c.vel_d_xy, c.vel_p_z, c.vel_i_z, c.vel_d_z,
                         c.vel_i_limit, c.max_vel_xy, c.max_vel_up, c.max_vel_down, (a[0], a[1], a[2]), c.yaw_weight)


class Cascade:
    """The full controller for one vehicle; see the module docstring.

    Use :meth:`set_position` / :meth:`set_velocity_z` etc. through the attributes, call
    :meth:`update_position` at the position-loop rate and :meth:`update_attitude` every step.
    """

    def __init__(self, vehicle: VehicleSpec, dt: float) -> None:
        c = vehicle.control
        self.vehicle = vehicle
        self.dt = dt
        self.mixer = Mixer(vehicle)
        self.c = c
        self.gains = LoopGains.of(c)
        self.t_total_max = self.mixer.n * self.mixer.t_max
        self.thr_min = c.thrust_min_frac * self.t_total_max
        self.thr_max = c.thrust_max_frac * self.t_total_max
        self.tan_tilt = math.tan(math.radians(c.max_tilt_deg))
        self.torque_scale = self.mixer.torque_scale
        mr = c.max_rate_deg_s
        self.max_rate: Vec3 = (math.radians(mr[0]), math.radians(mr[1]), math.radians(mr[2]))
        self.vel_d_tau = 1.0 / (2.0 * math.pi * c.vel_d_cutoff_hz)
        # setpoints (ENU): position, velocity feed-forward, yaw
        self.pos_sp: Vec3 = (0.0, 0.0, 0.0)
        self.vel_ff: Vec3 = (0.0, 0.0, 0.0)
        self.acc_ff: Vec3 = (0.0, 0.0, 0.0)
        self.xy_pos_ctrl = True  # False: horizontal velocity = vel_ff
        self.z_pos_ctrl = True  # False: vertical velocity = vel_ff[2]
        self.yaw_sp = 0.0
        self.yaw_cur = 0.0  # slewed yaw setpoint, rad
        self.yaw_rate_max = math.radians(c.max_yaw_rate_auto_deg_s)
        self.reset()

    def reset(self) -> None:
        """Zero all integrators and filters."""
        self.vel_int = [0.0, 0.0, 0.0]
        self._prev_vel: Vec3 | None = None
        self._acc_f = [0.0, 0.0, 0.0]
        c = self.c
        pids = [Pid(c.rate_p[i], c.rate_i[i], c.rate_d[i], i_limit=c.rate_i_limit, d_cutoff_hz=c.rate_d_cutoff_hz)
                for i in (0, 1, 2)]
        self.rate_pid: tuple[Pid, Pid, Pid] = (pids[0], pids[1], pids[2])  # roll, pitch, yaw
        self.q_sp: QuatXYZW = (0.0, 0.0, 0.0, 1.0)
        self.thrust_sp = 0.0  # N collective
        self.thrust_up = 0.0  # N, vertical component of the thrust vector setpoint
        self.freeze_rate_i = False  # rate integrators held (PX4: while maybe landed or landed)
        self.vel_sp: Vec3 = (0.0, 0.0, 0.0)
        self.acc_sp: Vec3 = (0.0, 0.0, 0.0)
        self.rate_sp: Vec3 = (0.0, 0.0, 0.0)
        self.torque_norm: Vec3 = (0.0, 0.0, 0.0)
        self.thrust_saturated = 0  # +1 at max, -1 at min

    def reset_rate_integrators(self) -> None:
        """Zero the rate integrators (on the ground, as PX4 does while landed)."""
        for pid in self.rate_pid:
            pid.integral = 0.0

    def update_hover_mass(self, mass_old: float, mass_new: float) -> None:
        """The hover thrust feed-forward changes from ``mass_old`` to ``mass_new`` kg (a new hover thrust
        estimate): shift the vertical velocity integrator so that the thrust stays the same (PX4
        ``PositionControl::updateHoverThrust``)."""
        az = self.acc_sp[2]
        self.vel_int[2] = self.vel_int[2] + ((az + G) * mass_old / mass_new - G - az)

    def ground_contact(self) -> None:
        """On the ground while flying (PX4 "flying but ground contact"): minimum collective thrust, level
        attitude at the current yaw, velocity integrators zeroed, until the land detector decides."""
        self.vel_int = [0.0, 0.0, 0.0]
        self.thrust_sp = self.thrust_up = self.thr_min
        self.thrust_saturated = -1
        self.q_sp = thrust_to_attitude(0.0, 0.0, 1.0, self.yaw_cur)

    # ------------------------------------------------------------------ position / velocity loop
    def update_position(self, pos: Vec3, vel: Vec3, mass_kg: float, dt: float) -> None:
        """Position P + velocity PID -> thrust vector -> (q_sp, thrust_sp). ENU, SI."""
        c = self.gains
        ffx, ffy, ffz = self.vel_ff
        if self.xy_pos_ctrl:
            vx = ffx + c.pos_p_xy * (self.pos_sp[0] - pos[0])
            vy = ffy + c.pos_p_xy * (self.pos_sp[1] - pos[1])
        else:
            vx, vy = ffx, ffy
        vh = math.sqrt(vx * vx + vy * vy)
        if vh > c.max_vel_xy:
            k = c.max_vel_xy / vh
            vx *= k
            vy *= k
        vz = ffz + c.pos_p_z * (self.pos_sp[2] - pos[2]) if self.z_pos_ctrl else ffz
        if vz > c.max_vel_up:
            vz = c.max_vel_up
        elif vz < -c.max_vel_down:
            vz = -c.max_vel_down
        self.vel_sp = (vx, vy, vz)
        ex, ey, ez = vx - vel[0], vy - vel[1], vz - vel[2]
        # filtered measured acceleration for the D term
        pv = self._prev_vel
        af = self._acc_f
        if pv is not None and dt > 0.0:
            a = dt / (self.vel_d_tau + dt)
            af[0] = af[0] + (a * ((vel[0] - pv[0]) / dt - af[0]))
            af[1] = af[1] + (a * ((vel[1] - pv[1]) / dt - af[1]))
            af[2] = af[2] + (a * ((vel[2] - pv[2]) / dt - af[2]))
        self._prev_vel = vel
        vi = self.vel_int
        aff = self.acc_ff
        ax = aff[0] + c.vel_p_xy * ex + vi[0] - c.vel_d_xy * af[0]
        ay = aff[1] + c.vel_p_xy * ey + vi[1] - c.vel_d_xy * af[1]
        az = aff[2] + c.vel_p_z * ez + vi[2] - c.vel_d_z * af[2]
        # vertical thrust with priority
        m = mass_kg
        fz = m * (az + G)
        sat_z = 0
        if fz > self.thr_max:
            fz, sat_z = self.thr_max, 1
        elif fz < self.thr_min:
            fz, sat_z = self.thr_min, -1
        # horizontal: tilt limit and the thrust left after the vertical part
        fx_req, fy_req = m * ax, m * ay
        fh_req = math.sqrt(fx_req * fx_req + fy_req * fy_req)
        fh_max = fz * self.tan_tilt
        rem = self.thr_max * self.thr_max - fz * fz
        fh_thr = math.sqrt(rem) if rem > 0.0 else 0.0
        if fh_thr < fh_max:
            fh_max = fh_thr
        if fh_req > fh_max:
            k = fh_max / fh_req
            fx, fy = fx_req * k, fy_req * k
        else:
            fx, fy = fx_req, fy_req
        self.acc_sp = (fx / m, fy / m, fz / m - G)
        # integrators with anti-windup
        if not ((sat_z > 0 and ez > 0.0) or (sat_z < 0 and ez < 0.0)):
            vi[2] = vi[2] + (c.vel_i_z * ez * dt)
        if fh_req > fh_max and c.vel_p_xy > 0.0:
            arw = 2.0 / c.vel_p_xy
            ex -= arw * (ax - fx / m)
            ey -= arw * (ay - fy / m)
        vi[0] = vi[0] + (c.vel_i_xy * ex * dt)
        vi[1] = vi[1] + (c.vel_i_xy * ey * dt)
        lim = c.vel_i_limit
        for i in (0, 1):
            if vi[i] > lim:
                vi[i] = lim
            elif vi[i] < -lim:
                vi[i] = -lim
        # vertical: PX4 limits the thrust integral to g (a load the hover thrust does not know yet)
        if vi[2] > G:
            vi[2] = G
        elif vi[2] < -G:
            vi[2] = -G
        self.thrust_saturated = sat_z
        self.thrust_up = fz
        self.thrust_sp = math.sqrt(fx * fx + fy * fy + fz * fz)
        # yaw setpoint slewed towards yaw_sp (MPC_YAWRAUTO_MAX)
        dy = self.yaw_sp - self.yaw_cur
        dy = (dy + math.pi) % (2.0 * math.pi) - math.pi
        step = self.yaw_rate_max * dt
        self.yaw_cur += step if dy > step else (-step if dy < -step else dy)
        self.q_sp = thrust_to_attitude(fx, fy, fz, self.yaw_cur)

    def set_yaw(self, yaw: float, *, immediate: bool = False) -> None:
        """Yaw setpoint (rad, ENU from east CCW); slewed at MPC_YAWRAUTO_MAX unless ``immediate``."""
        self.yaw_sp = yaw
        if immediate:
            self.yaw_cur = yaw

    def set_attitude(self, q_sp: QuatXYZW, thrust_n: float) -> None:
        """Direct attitude + collective thrust setpoint (bypasses the position loop)."""
        self.q_sp = q_sp
        self.thrust_sp = thrust_n

    # ------------------------------------------------------------------ attitude + rate loop
    def update_attitude(self, q: QuatXYZW, omega: Vec3, dt: float) -> tuple[float, ...]:
        """Attitude P + rate PID + allocation -> rotor speed commands (rad/s)."""
        c = self.gains
        rsx, rsy, rsz = attitude_rate_setpoint(q, self.q_sp, c.att_p, c.yaw_weight)
        mr = self.max_rate
        rsx = mr[0] if rsx > mr[0] else (-mr[0] if rsx < -mr[0] else rsx)
        rsy = mr[1] if rsy > mr[1] else (-mr[1] if rsy < -mr[1] else rsy)
        rsz = mr[2] if rsz > mr[2] else (-mr[2] if rsz < -mr[2] else rsz)
        self.rate_sp = (rsx, rsy, rsz)
        ox, oy, oz = omega
        px, py, pz = self.rate_pid
        ex, ey, ez = rsx - ox, rsy - oy, rsz - oz
        ux = px.output(ex, ox, dt)
        uy = py.output(ey, oy, dt)
        uz = pz.output(ez, oz, dt)
        self.torque_norm = (ux, uy, uz)
        ts = self.torque_scale
        mixer = self.mixer
        w_cmd = mixer.rotor_speeds(mixer.allocate_thrusts(self.thrust_sp, ux * ts[0], uy * ts[1], uz * ts[2]))
        # rate integrators, frozen in the direction the mixer saturated (and on the ground)
        if not self.freeze_rate_i:
            _st, sx, sy, sz = mixer.saturation
            px.integrate(ex, dt, sx)
            py.integrate(ey, dt, sy)
            pz.integrate(ez, dt, sz)
        return w_cmd
