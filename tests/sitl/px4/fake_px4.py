"""An in-repo fake PX4 SITL peer: speaks both of PX4's links like PX4 does, for CI.

Simulator link (docs/firmware-protocols.md §1): TCP client to 4560+i, retrying until the
simulator listens; sends ONE HEARTBEAT (autopilot 12) and COMMAND_LONG SET_MESSAGE_INTERVAL
(115, 5000 µs); after ``boot_steps`` HIL_SENSORs it answers each HIL_SENSOR (id 0) with
HIL_ACTUATOR_CONTROLS carrying the same ``time_usec``, ``mode`` 1 | 128 when armed, ``flags`` 1.
Every field received is checked (units, frames, bitmasks, time steps) and each problem is
appended to :attr:`FakePx4.violations`.

API link (§1.1, §4.4): the vehicle endpoint (:class:`vinecli.mavlink.vehicle.VehicleEndpoint`,
sysid i+1, compid 1, autopilot 12) bound to UDP 14580+i sending to 14540+i: heartbeat,
SYS_STATUS with the pre-arm bit, mission upload server, parameters, arm/mode commands with
COMMAND_ACK, MISSION_CURRENT / MISSION_ITEM_REACHED, EXTENDED_SYS_STATE.

Outputs are computed by the built-in controller (:class:`vinecli.autopilot.builtin.BuiltinAutopilot`
with ground truth, driven through :class:`vinecli.autopilot.mavlink_vehicle.MavlinkControlledAutopilot`)
from HIL_STATE_QUATERNION, flying the uploaded mission; rotor speeds are turned back into PX4
outputs u = (w - w_min) / (w_max - w_min).

Failure modes for tests: ``reject_arm`` (arming denied with that STATUSTEXT), ``silent_after_s``
(stop sending anything on both links after that much simulated time), ``garbage_at_s`` (at that simulated time,
1.5 kB of random bytes on the simulator link just before an answer, ending in the start of a MAVLink 2 frame
that claims 255 bytes: the answer is swallowed, as line noise would), ``silent_from_item`` (items from that one on are
never reported reached nor the mission complete: a PX4 that lands and disarms before the last report),
``lost_wakeup_at_s`` (the HIL_SENSOR at that simulated time gets no answer and the next one is answered, as PX4 v1.15
does when its lockstep loses a wakeup: its sender waits for a component that reports only once the clock moves).
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from vinecli.autopilot.base import AutopilotContext
from vinecli.autopilot.mavlink_vehicle import MavlinkControlledAutopilot
from vinecli.frames import (
    attitude_ned_frd_to_enu_flu,
    frd_to_flu,
    ned_to_enu,
    norm,
    quat_rotate,
    wxyz_to_xyzw,
)
from vinecli.geo import GeoOrigin
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.link import TcpClientLink, UdpLink
from vinecli.sim.perfect_estimator import PerfectEstimator
from vinecli.specs.mission import HoldPhase, MissionSpec
from vinecli.specs.vehicle import VehicleSpec
from vinecli.types import ImuSample, Observation, RigidState

G0 = 9.80665


@dataclass
class FakeStats:
    hil_sensor: int = 0
    hil_gps: int = 0
    hil_state: int = 0
    mag_updates: int = 0  # HIL_SENSOR with the mag bits set
    baro_updates: int = 0
    answered: int = 0
    armed_answers: int = 0
    max_alt_rel: float = 0.0
    first_gps: tuple[float, float, float] | None = None
    step_us: int | None = None
    spray_u_max: float = 0.0
    mode_words: set[int] = field(default_factory=set)


class _FakeVehicle(MavlinkControlledAutopilot):
    """The fake PX4's flight stack: the builtin autopilot behind the vehicle endpoint."""

    reject_arm: str | None = None
    silent_from_item: int | None = None

    def on_arm(self, arm: bool, force: bool) -> tuple[int, str]:
        if arm and self.reject_arm:
            return M.MAV_RESULT_DENIED, self.reject_arm
        return super().on_arm(arm, force)

    def _telemetry(self, obs: Observation) -> Any:
        t = super()._telemetry(obs)
        if self.silent_from_item is not None:  # lands and disarms without reporting the items from there on
            t.mission_seq = min(t.mission_seq, self.silent_from_item - 1)
            t.mission_state = M.MISSION_STATE_ACTIVE if t.mission_state == M.MISSION_STATE_COMPLETE else t.mission_state
        return t


class FakePx4:
    """Run with :meth:`start` (a thread), stop with :meth:`stop`; see the module docstring."""

    def __init__(self, vehicle: VehicleSpec, origin: GeoOrigin, *, sim_port: int, api_local_port: int, api_remote_port: int,
                 instance: int = 0, host: str = "127.0.0.1", step_us: int = 4000, boot_steps: int = 25,
                 reject_arm: str | None = None, silent_after_s: float | None = None, connect_timeout_s: float = 20.0,
                 fill_l: float | None = None, garbage_at_s: float | None = None,
                 silent_from_item: int | None = None, lost_wakeup_at_s: float | None = None) -> None:
        self.vehicle, self.origin = vehicle, origin
        self.host, self.sim_port = host, sim_port
        self.api_local_port, self.api_remote_port = api_local_port, api_remote_port
        self.instance = instance
        self.expected_step_us = step_us
        self.boot_steps = boot_steps
        self.reject_arm = reject_arm
        self.silent_after_s = silent_after_s
        self.garbage_at_s = garbage_at_s
        self.silent_from_item = silent_from_item
        self.lost_wakeup_at_s = lost_wakeup_at_s
        self.lost_answer_t: int | None = None  # the HIL_SENSOR time_usec left unanswered
        self.garbage_sent = 0
        self.connect_timeout_s = connect_timeout_s
        self.fill_l = (vehicle.tank.capacity_l if vehicle.tank else 0.0) if fill_l is None else fill_l
        self.violations: list[str] = []
        self.stats = FakeStats()
        self.connected = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._last_t: int | None = None
        self._t0: int | None = None
        self._state: RigidState | None = None
        self._state_t: int | None = None
        self._last_gps_epoch: int | None = None
        from vinecli.flight.magnetic import earth_field

        self.wmm = earth_field(origin)
        self.ap: _FakeVehicle | None = None
        self.home_enu: tuple[float, float, float] | None = None
        self.silent = False
        self.error: BaseException | None = None

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> FakePx4:
        self._thread = threading.Thread(target=self._main, name="fake-px4", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)

    def _violation(self, text: str) -> None:
        if len(self.violations) < 200:
            self.violations.append(text)

    def _main(self) -> None:
        try:
            self._run()
        except BaseException as exc:  # noqa: BLE001 - reported to the test
            self.error = exc

    def _run(self) -> None:
        tcp = TcpClientLink(self.host, self.sim_port, src_system=self.instance + 1, src_component=1)
        if not tcp.connect(self.connect_timeout_s, stop=self._stop):
            return
        self.tcp = tcp
        self.connected.set()
        mav = tcp.mav
        tcp.send(mav.heartbeat_encode(M.MAV_TYPE_QUADROTOR, M.MAV_AUTOPILOT_PX4, M.MODE_FLAG_CUSTOM, 0, M.MAV_STATE_STANDBY))
        tcp.send(mav.command_long_encode(0, 0, M.CMD_SET_MESSAGE_INTERVAL, 0, 115, 5000, 0, 0, 0, 0, 0))
        self.udp: UdpLink | None = None
        try:
            while not self._stop.is_set():
                m = tcp.recv(0.05)
                if m is None:
                    if tcp.closed_by_peer.is_set():
                        return
                    continue
                typ = m.get_type()
                if typ == "HIL_SENSOR":
                    self._on_sensor(m)
                elif typ == "HIL_GPS":
                    self._on_gps(m)
                elif typ == "HIL_STATE_QUATERNION":
                    self._on_state(m)
                else:
                    self._violation(f"unexpected message on the simulator link: {typ}")
        finally:
            tcp.close()
            if self.ap is not None:
                self.ap.close()
            if self.udp is not None:
                self.udp.close()

    # ------------------------------------------------------------------ checks
    def _on_state(self, m: object) -> None:
        st = self.stats
        st.hil_state += 1
        q = tuple(m.attitude_quaternion)  # type: ignore[attr-defined]
        if abs(math.sqrt(sum(c * c for c in q)) - 1.0) > 1e-3:
            self._violation(f"HIL_STATE_QUATERNION attitude not unit: {q}")
        lat_e7, lon_e7, alt_mm = m.lat, m.lon, m.alt  # type: ignore[attr-defined]
        m_lat, m_lon = self.origin.metres_per_degree
        x = (lon_e7 * 1e-7 - self.origin.lon) * m_lon
        y = (lat_e7 * 1e-7 - self.origin.lat) * m_lat
        z = alt_mm * 1e-3 - self.origin.alt
        if abs(x) > 5000 or abs(y) > 5000 or abs(z) > 1000:
            self._violation(f"HIL_STATE_QUATERNION position far from the origin: {x:.0f}, {y:.0f}, {z:.0f} m")
        vel = ned_to_enu((m.vx * 0.01, m.vy * 0.01, m.vz * 0.01))  # type: ignore[attr-defined]
        quat = attitude_ned_frd_to_enu_flu(wxyz_to_xyzw(q))  # type: ignore[arg-type]
        omega = frd_to_flu((m.rollspeed, m.pitchspeed, m.yawspeed))  # type: ignore[attr-defined]
        if self.home_enu is None:
            self.home_enu = (x, y, z)
        on_ground = z <= self.home_enu[2] + 0.03 and abs(vel[2]) < 0.3
        self._state = RigidState(m.time_usec, (x, y, z), quat, vel, omega, (0.0, 0.0, 0.0), on_ground)  # type: ignore[attr-defined]
        self._state_t = m.time_usec  # type: ignore[attr-defined]
        self.stats.max_alt_rel = max(self.stats.max_alt_rel, z - self.home_enu[2])

    def _on_gps(self, m: object) -> None:
        st = self.stats
        st.hil_gps += 1
        g = m  # type: ignore[assignment]
        if g.fix_type != 3:  # type: ignore[attr-defined]
            self._violation(f"HIL_GPS fix_type {g.fix_type} != 3")  # type: ignore[attr-defined]
        if g.satellites_visible < 6:  # type: ignore[attr-defined]
            self._violation(f"HIL_GPS satellites {g.satellites_visible} < 6")  # type: ignore[attr-defined]
        if not (5 <= g.eph <= 300 and 5 <= g.epv <= 500):  # type: ignore[attr-defined]
            self._violation(f"HIL_GPS eph/epv {g.eph}/{g.epv} not in cm within EKF2 limits")  # type: ignore[attr-defined]
        if g.time_usec < 1_500_000_000_000_000:  # type: ignore[attr-defined]
            self._violation(f"HIL_GPS time_usec {g.time_usec} is not UNIX-epoch µs")  # type: ignore[attr-defined]
        if self._last_gps_epoch is not None and g.time_usec <= self._last_gps_epoch:  # type: ignore[attr-defined]
            self._violation("HIL_GPS time_usec not increasing")
        self._last_gps_epoch = g.time_usec  # type: ignore[attr-defined]
        lat, lon, alt = g.lat * 1e-7, g.lon * 1e-7, g.alt * 1e-3  # type: ignore[attr-defined]
        if st.first_gps is None:
            st.first_gps = (lat, lon, alt)
            m_lat, m_lon = self.origin.metres_per_degree
            dn, de = (lat - self.origin.lat) * m_lat, (lon - self.origin.lon) * m_lon
            if math.hypot(dn, de) > 5.0:
                self._violation(f"first HIL_GPS fix {math.hypot(dn, de):.1f} m from the world origin")
            if abs(alt - self.origin.alt) > 10.0:
                self._violation(f"first HIL_GPS altitude {alt:.1f} m vs origin {self.origin.alt:.1f} m (alt must be mm AMSL)")
        if g.cog != 65535 and not 0 <= g.cog < 36000:  # type: ignore[attr-defined]
            self._violation(f"HIL_GPS cog {g.cog} out of range")  # type: ignore[attr-defined]

    def _on_sensor(self, m: object) -> None:
        st = self.stats
        st.hil_sensor += 1
        s = m  # type: ignore[assignment]
        t = s.time_usec  # type: ignore[attr-defined]
        f = s.fields_updated  # type: ignore[attr-defined]
        # accel|gyro every step; mag / baro as complete groups (PX4 ignores partial ones), only with new samples
        if f & 63 != 63 or f & 448 not in (0, 448) or f & 6656 not in (0, 6656) or f & ~7167:
            self._violation(f"HIL_SENSOR fields_updated {f}: accel|gyro every step, complete mag/baro groups")
        st.mag_updates += bool(f & 448)
        st.baro_updates += bool(f & 6656)
        if s.id != 0:  # type: ignore[attr-defined]
            self._violation(f"HIL_SENSOR id {s.id} != 0")  # type: ignore[attr-defined]
        if t <= 0:
            self._violation("HIL_SENSOR time_usec must be > 0")
        if self._last_t is not None and t - self._last_t != self.expected_step_us:
            self._violation(f"HIL_SENSOR time step {t - self._last_t} µs != {self.expected_step_us}")
        self._last_t = t
        if self._t0 is None:
            self._t0 = t
        acc = (s.xacc, s.yacc, s.zacc)  # type: ignore[attr-defined]
        gyro = (s.xgyro, s.ygyro, s.zgyro)  # type: ignore[attr-defined]
        mag = (s.xmag, s.ymag, s.zmag)  # type: ignore[attr-defined]
        if not all(math.isfinite(v) for v in (*acc, *gyro, *mag)):
            self._violation("HIL_SENSOR has non-finite values")
            return
        if not 300.0 <= s.abs_pressure <= 1100.0:  # type: ignore[attr-defined]
            self._violation(f"HIL_SENSOR abs_pressure {s.abs_pressure} not in hPa")  # type: ignore[attr-defined]
        if not -60.0 <= s.temperature <= 60.0:  # type: ignore[attr-defined]
            self._violation(f"HIL_SENSOR temperature {s.temperature} not in °C")  # type: ignore[attr-defined]
        mn = norm(mag)
        if not 0.2 <= mn <= 0.7 or abs(mn - self.wmm.intensity_gauss) > 0.03:
            self._violation(f"HIL_SENSOR |mag| {mn:.3f} G (WMM at origin {self.wmm.intensity_gauss:.3f} G)")
        state = self._state
        if state is not None and self._state_t == t:
            if abs(s.pressure_alt - (self.origin.alt + state.pos[2])) > 20.0:  # type: ignore[attr-defined]
                self._violation(f"HIL_SENSOR pressure_alt {s.pressure_alt:.1f} m vs truth {self.origin.alt + state.pos[2]:.1f}")  # type: ignore[attr-defined]
            # magnetometer in body FRD: rotate back to NED and compare with the WMM field
            m_enu = quat_rotate(state.quat, frd_to_flu(mag))
            m_ned = (m_enu[1], m_enu[0], -m_enu[2])
            ref = self.wmm.ned_gauss
            if max(abs(a - b) for a, b in zip(m_ned, ref, strict=True)) > 0.02:
                self._violation(f"HIL_SENSOR mag not the WMM field in FRD: {m_ned} vs {ref}")
            settled = t - (self._t0 or t) > 500_000 and norm(state.vel) < 0.02
            if settled and state.on_ground and (self.ap is None or not self.ap.ap.armed):
                an = norm(acc)
                if abs(an - G0) > 0.5 or acc[2] > -9.0:
                    self._violation(f"HIL_SENSOR at rest: specific force {acc} (FRD, expected ≈ (0, 0, -9.81))")
                if norm(gyro) > 0.1:
                    self._violation(f"HIL_SENSOR at rest: gyro {gyro} rad/s")
        elif state is not None or st.hil_state > 0:
            self._violation("HIL_STATE_QUATERNION for this step missing or out of order")
        sim_s = (t - self._t0) * 1e-6
        if self.silent_after_s is not None and sim_s >= self.silent_after_s:
            self.silent = True
            return
        if self.ap is None and state is not None:
            self._start_vehicle(t)
        controls = [0.0] * 16
        mode = M.MODE_FLAG_CUSTOM
        if self.ap is not None and state is not None:
            obs = Observation(t, state, ImuSample(t, frd_to_flu(acc), frd_to_flu(gyro)), tank_level_l=self.fill_l)
            cmd = self.ap.step(obs)
            if cmd.armed:
                mode |= M.MODE_FLAG_SAFETY_ARMED
                px4 = self.vehicle.px4
                chans = px4.motor_channels or list(range(self.vehicle.n_rotors))
                span = self.vehicle.motor.w_max - px4.w_min_rad_s
                for ch, w in zip(chans, cmd.rotor_speed_cmd, strict=True):
                    controls[ch] = max(0.0, min(1.0, (w - px4.w_min_rad_s) / span))
                if self.vehicle.tank is not None:
                    controls[px4.sprayer_channel] = cmd.spray_flow_lps / self.vehicle.tank.nozzle_max_flow_lps
                    st.spray_u_max = max(st.spray_u_max, controls[px4.sprayer_channel])
        if st.hil_sensor <= self.boot_steps:
            return  # pwm_out_sim not running yet
        if self.lost_wakeup_at_s is not None and self.lost_answer_t is None and sim_s >= self.lost_wakeup_at_s:
            self.lost_answer_t = t
            return
        st.answered += 1
        if mode & M.MODE_FLAG_SAFETY_ARMED:
            st.armed_answers += 1
        st.mode_words.add(mode)
        if self.garbage_at_s is not None and not self.garbage_sent and sim_s >= self.garbage_at_s:
            import random

            rng = random.Random(7)
            noise = bytes(rng.choice([b for b in range(256) if b not in (0xFD, 0xFE)]) for _ in range(1500))
            self.garbage_sent = len(noise) + 3
            self.tcp._send_bytes(noise + bytes([0xFD, 0xFF, 0x00]))  # a frame of 255 bytes begins: swallows the answer
        self.tcp.send(self.tcp.mav.hil_actuator_controls_encode(t, controls, mode, M.HIL_ACTUATOR_CONTROLS_FLAGS_LOCKSTEP))

    def _start_vehicle(self, t: int) -> None:
        """PX4's API link comes up once HIL_SENSOR streams (rcS unblocks)."""
        self.udp = UdpLink((self.host, self.api_local_port), (self.host, self.api_remote_port), reply_to_sender=True,
                           src_system=self.instance + 1, src_component=1)
        ap = _FakeVehicle(link=self.udp, instance=self.instance, pace=False)
        ap.reject_arm = self.reject_arm
        ctx = AutopilotContext(  # flies on the simulator's truth (from HIL_STATE_QUATERNION): a perfect estimator
            mission=MissionSpec(name="fake-px4", phases=[HoldPhase(duration_s=1.0)]), vehicle=self.vehicle,
            origin=self.origin, home_enu=self.home_enu or (0.0, 0.0, 0.0), physics_dt_us=self.expected_step_us,
            estimator=PerfectEstimator())
        ap.reset(ctx)
        if self.silent_from_item is not None:
            ap.silent_from_item = n = self.silent_from_item
            reached = ap.endpoint.mission_item_reached
            ap.endpoint.mission_item_reached = lambda seq: None if seq >= n else reached(seq)  # type: ignore[method-assign]
        ap.endpoint.missions = {0: [], 1: [], 2: []}
        ap.mission_state = 0
        self.ap = ap


def wait_until(cond: object, timeout: float) -> bool:
    """Poll ``cond()`` until true or ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():  # type: ignore[operator]
            return True
        time.sleep(0.02)
    return False
