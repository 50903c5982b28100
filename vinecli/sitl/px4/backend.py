"""PX4 SITL backend: vinecli is the simulator side of PX4's ``simulator_mavlink`` (TCP 4560+i).

Protocol (docs/firmware-protocols.md §1): vinecli listens on TCP ``host:4560+instance``; PX4
connects, sends one HEARTBEAT and SET_MESSAGE_INTERVAL(115). Each physics step vinecli sends

* HIL_STATE_QUATERNION (optional ground truth, sent *first* so a peer answering on
  HIL_SENSOR sees the state of the same step; PX4 only logs it),
* HIL_SENSOR: specific force and rates in body FRD, magnetic field in gauss (FRD), pressure in
  hPa, temperature °C, pressure altitude m, ``id`` 0; ``fields_updated`` has accel|gyro every
  step and the mag (448) / baro (6656) bits only on steps where that sensor model produced a new
  sample (as Gazebo does; the values in between are sample-and-hold),
* HIL_GPS whenever the GNSS model has a new sample (10 Hz by default; noise is the vehicle's
  ``sensors.gnss`` spec), with ``time_usec`` in UNIX-epoch µs, eph/epv in cm.

HIL time = sim time + one step (never 0), strictly increasing by exactly the physics step. **Boot phase** (until the
first HIL_ACTUATOR_CONTROLS): motors off, steps paced at wall-clock rate, so PX4 boots in real time. **Lockstep
phase**: after sending HIL_SENSOR(t) the step waits for HIL_ACTUATOR_CONTROLS with ``time_usec >= t``: PX4's clock
does not move until it gets the next HIL_SENSOR, so however long a loaded machine makes that take, the flight is the
same (the wait is the lockstep, not a race with the wall clock). One answer PX4 itself loses (a lost wakeup in its
lockstep, :mod:`vinecli.sitl.px4.lockstep`) is recovered after 2 s of wall time by sending the next step
(``px4_lockstep_recoveries``). Only a PX4 that exited, closed the link or sent nothing for ``hang_timeout_s``
(default 30 s) ends the run, with an error. With an explicit ``step_timeout_s``
(``--px4-lockstep-timeout``) a step instead proceeds after that long with the last controls and counts a stall
(``px4_stalls``: any stall fails the run's checks); ``max_stalls`` consecutive stalls raise AutopilotError (PX4
stopped answering). Outputs map to rotor speeds with the vehicle's ``px4.motor_channels``: w = w_min + u (w_max -
w_min) while armed (mode bit 128), 0 disarmed; the sprayer channel gives flow = clamp(u, 0, 1) * nozzle_max_flow.

Mission control runs on PX4's API link (UDP 14540+i) in a background thread (``Px4MissionClient`` of
:mod:`vinecli.sitl.px4.mission_client`); ``step`` only polls its state: the lockstep never waits for mission traffic.
"""

from __future__ import annotations

import logging
import math
import time
from typing import TYPE_CHECKING, Any

from vinecli.autopilot.base import AutopilotContext, AutopilotStatus, RunStatus
from vinecli.constants import STANDARD_GRAVITY
from vinecli.errors import AutopilotError, AutopilotTimeout, FirmwareUnreachable, InputError
from vinecli.frames import attitude_grid_to_ned_frd, flu_to_frd, grid_to_ned, quat_rotate_inv, xyzw_to_wxyz
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.link import TcpServerLink
from vinecli.sitl.converter import pump_max_flow_lps
from vinecli.sitl.dose_follow import follow_event
from vinecli.sitl.px4.lockstep import Px4Lockstep
from vinecli.sitl.px4.log_audit import apply_audit
from vinecli.sitl.px4.process import px4_start_command
from vinecli.sitl.takeoff import TakeoffWatch
from vinecli.specs.mission import TakeoffPhase
from vinecli.types import ActuatorCommand, Event, Observation

if TYPE_CHECKING:
    from vinecli.sitl.record import FirmwareRecord

log = logging.getLogger(__name__)

SIM_PORT_BASE = 4560
API_PORT_BASE = 14540  # vinecli binds (PX4 sends here)
PX4_API_LOCAL_BASE = 14580  # PX4 binds (vinecli sends here)
G0 = STANDARD_GRAVITY
#: simulated UTC at t = 0 (HIL_GPS time_usec): 2025-07-01T00:00:00Z
EPOCH_US = 1_751_328_000_000_000
#: files of PX4's working directory kept in the run folder: its logs, console output, boot parameters
KEEP = ("rootfs/log/*/*.ulg", "px4.log", "rc/px4-rc.params")


class Px4SitlAutopilot(Px4Lockstep):
    """Autopilot backend driving a real (or fake) PX4 over the SITL protocol.

    Options: ``host`` (bind address, default 127.0.0.1; a non-loopback address needs
    ``allow_remote=True``), ``instance`` (PX4 ``-i``), ``port`` (default 4560+instance),
    ``connect_timeout_s`` (wait for PX4 to connect, default 30), ``step_timeout_s`` (None: wait for
    PX4's answer each step, the lockstep; a number: proceed after that long, a stall), ``hang_timeout_s``
    (lockstep: no answer for that long is an error, default 30), ``max_stalls`` (consecutive stalls ->
    error, default 10),
    ``boot_timeout_s`` (connected but no actuator controls, default 60), ``hil_state`` (send
    HIL_STATE_QUATERNION, default True), ``api_port`` (UDP port vinecli binds for PX4's API link,
    default 14540+instance), ``px4_api_port`` (PX4's API port, default 14580+instance),
    ``mission`` (False: no mission control, just the sensor/actuator link), ``health_timeout_s``,
    ``px4_bin`` (a PX4 SITL binary: vinecli starts PX4 itself for this run on a free instance,
    unless ``instance`` is given, with a fresh working directory, and stops it in :meth:`close`),
    ``px4_workdir`` (keep PX4's working directory and log there instead of a temporary one),
    ``cannot_takeoff_s`` (armed, motors saturated and not climbing for this long ->
    ``cannot_take_off``, default the vehicle's ``control.cannot_takeoff_s``).
    """

    name = "px4"

    # parameters: keyword-only options, each with its default, one per PX4 option of `vinecli run mission` or test knob; a caller names the ones it sets
    def __init__(self, *, host: str = "127.0.0.1", instance: int | None = None, port: int | None = None,
                 connect_timeout_s: float = 30.0, step_timeout_s: float | None = None, max_stalls: int = 10,
                 hang_timeout_s: float = 30.0,
                 boot_timeout_s: float = 60.0, hil_state: bool = True, api_port: int | None = None,
                 px4_api_port: int | None = None, mission: bool = True, health_timeout_s: float = 120.0,
                 allow_remote: bool = False, px4_bin: str | None = None, px4_workdir: str | None = None,
                 cannot_takeoff_s: float | None = None, **opts: Any) -> None:
        if opts:
            raise InputError(f"px4 autopilot: unknown option(s) {', '.join(sorted(opts))}")
        if instance is not None and not (0 <= instance <= 99):
            raise InputError(f"px4 autopilot: instance {instance} out of range 0..99")
        if not ((step_timeout_s is None or step_timeout_s > 0) and max_stalls >= 1 and hang_timeout_s > 0):
            raise InputError("px4 autopilot: step_timeout_s and hang_timeout_s must be > 0 and max_stalls >= 1")
        from vinecli.mavlink.link import is_loopback

        if not is_loopback(host) and not allow_remote:
            raise InputError(f"px4 autopilot: refusing to listen on non-loopback address {host} (add --px4-allow-remote)")
        self.host = host
        self.connect_timeout_s, self.step_timeout_s = connect_timeout_s, step_timeout_s
        self.max_stalls, self.boot_timeout_s, self.hang_timeout_s = max_stalls, boot_timeout_s, hang_timeout_s
        self.hil_state = hil_state
        self._port_opt, self._api_port_opt, self._px4_api_port_opt = port, api_port, px4_api_port
        self._set_instance(0 if instance is None else instance)
        self._auto_instance = px4_bin is not None and instance is None
        self.use_mission, self.health_timeout_s = mission, health_timeout_s
        self.px4_bin, self.px4_workdir = px4_bin, px4_workdir
        self.cannot_takeoff_s = cannot_takeoff_s
        self.process: Any = None
        self._instance_lock: Any = None
        self.link: TcpServerLink | None = None
        self.mission_client: Any = None
        self.mission_version: Any = None  # PX4's AUTOPILOT_VERSION (identity)
        self.firmware_record: FirmwareRecord | None = None  # identity and kept logs after close()
        self._events: list[Event] = []
        self._status = AutopilotStatus(mode="BOOT", phase_index=0)
        self._closed = False

    def _set_instance(self, instance: int) -> None:
        self.instance = instance
        self.port = SIM_PORT_BASE + instance if self._port_opt is None else self._port_opt
        default_api = (API_PORT_BASE + instance if instance <= 9 else 14549)
        self.api_port = default_api if self._api_port_opt is None else self._api_port_opt
        self.px4_api_port = PX4_API_LOCAL_BASE + instance if self._px4_api_port_opt is None else self._px4_api_port_opt

    # ------------------------------------------------------------------ protocol
    def start_command(self) -> str:
        """How to start PX4 against this backend."""
        return px4_start_command(self.instance, self.host, self.px4_bin or "px4")

    def reset(self, ctx: AutopilotContext) -> None:
        """Convert the mission, listen on TCP, wait for PX4 to connect (AutopilotTimeout otherwise)."""
        from vinecli.sitl.px4.mission_client import plan_for

        self.ctx = ctx
        v = ctx.vehicle
        self.dt_us = ctx.physics_dt_us
        self.plan = plan_for(ctx) if self.use_mission else None  # SpecError before any socket is opened
        ch = v.px4.motor_channels if v.px4.motor_channels is not None else list(range(v.n_rotors))
        if len(ch) != v.n_rotors or any(not 0 <= c < 16 for c in ch):
            raise InputError(f"vehicle {v.name!r}: px4.motor_channels must give one channel 0..15 per rotor ({v.n_rotors})")
        self.channels = list(ch)
        self.w_min, self.w_max = v.px4.w_min_rad_s, v.motor.w_max
        self.spray_ch = v.px4.sprayer_channel
        self.nozzle = pump_max_flow_lps(v)  # the pump model's maximum: the firmware's pump output is a duty of it
        from vinecli.flight.magnetic import earth_field_world

        self.mag_world = earth_field_world(ctx.origin)
        self.gamma = ctx.origin.convergence_rad  # world (CRS grid) -> true north, at the firmware boundary
        self._mag_frd: tuple[float, float, float] | None = None
        self._baro: tuple[float, float, float] | None = None  # hPa, °C, m
        self.epoch_us = EPOCH_US  # HIL_GPS UTC: fixed, so two runs of a seed send the same bytes
        self._t_last: int | None = None
        self.lockstep = False
        self.armed = False
        self.controls: tuple[float, ...] = (0.0,) * 16
        self.stalls = self.resyncs = self.consecutive_stalls = self.recoveries = 0
        self._last_answer = (0, time.monotonic())  # PX4's last HIL_ACTUATOR_CONTROLS: time_usec, wall time received
        self.steps = 0
        self.lockstep_steps = 0
        self.hil_gps_sent = 0
        self.px4_heartbeat: Any = None
        first = ctx.mission.phases[0] if ctx.mission.phases else None
        self._takeoff = TakeoffWatch(self.cannot_takeoff_s or v.control.cannot_takeoff_s,
                                     first.timeout_s if isinstance(first, TakeoffPhase) else None)
        self.requested_state_interval_us: float | None = None
        self._events = []
        self._status = AutopilotStatus(mode="BOOT", phase_index=0, extra={})
        self._closed = False
        try:
            self._connect(ctx)
        except BaseException:
            self.close()  # nothing left listening after a failed start; its record kept (close() acts once)
            raise

    def _connect(self, ctx: AutopilotContext) -> None:
        from vinecli.sitl.px4.mission_client import Px4MissionClient

        if self.px4_bin is not None:
            self._prepare_process()
        self.link = TcpServerLink(self.host, self.port)
        if self.use_mission:
            self.mission_client = Px4MissionClient(
                self.plan, ctx, host=self.host, api_port=self.api_port, px4_port=self.px4_api_port,
                target_system=self.instance + 1, health_timeout_s=self.health_timeout_s)
        if self.process is not None:
            self.process.start()
            self._emit(0, "px4_process", f"PX4 started: instance {self.instance}, pid {self.process.proc.pid}",
                       {"instance": self.instance, "pid": self.process.proc.pid, "workdir": str(self.process.workdir)})
            self._accept_launched()
        else:
            try:
                self.link.accept(self.connect_timeout_s, hint=self.start_command())
            except AutopilotTimeout as exc:  # nobody started PX4 where the user said: exit 2, no run written
                raise FirmwareUnreachable(exc.problem) from None
        self._emit(0, "px4", f"PX4 connected on TCP {self.host}:{self.port}", {"peer": str(self.link.peer)})
        if self.plan is not None and (said := follow_event("px4", self.plan.rate_paths)) is not None:
            self._emit(0, *said)  # segment rates: what PX4 does with them
        hb = self.link.recv_match("HEARTBEAT", timeout=min(5.0, self.connect_timeout_s))
        if hb is None:
            raise AutopilotError(f"TCP {self.host}:{self.port}: the peer connected but sent no HEARTBEAT (is it PX4?)")
        self._on_msg(hb)
        self._boot_wall0: float | None = None
        if self.mission_client is not None:
            self.mission_client.start()

    def _prepare_process(self) -> None:
        """Reserve an instance (auto) and create the PX4 process object (not started yet)."""
        from vinecli.sitl.px4.process import Px4Process, reserve_instance

        if self._auto_instance:
            self._instance_lock = reserve_instance()
            self._set_instance(self._instance_lock.instance)
        if self._api_port_opt is None:
            self.api_port = 0  # PX4 answers whoever talks to its API port: no shared 14549 for instances > 9
        params = dict(self.plan.params) if self.plan is not None else dict(self.ctx.vehicle.px4.params)
        self.process = Px4Process(self.px4_bin, self.instance, workdir=self.px4_workdir,  # type: ignore[arg-type]
                                  airframe=self.ctx.vehicle.px4.airframe, params=params)

    def _accept_launched(self) -> None:
        """Accept the PX4 we started; fail early (with its log) if it exits first."""
        assert self.link is not None and self.process is not None
        deadline = time.monotonic() + self.connect_timeout_s
        while True:
            try:
                self.link.accept(min(0.5, max(0.01, deadline - time.monotonic())))
                return
            except AutopilotTimeout:
                if not self.process.alive():
                    raise AutopilotError(f"PX4 exited (code {self.process.proc.returncode}) before connecting to TCP "
                                         f"{self.host}:{self.port}" + self._px4_log()) from None
                if time.monotonic() >= deadline:
                    raise AutopilotTimeout(f"PX4 (instance {self.instance}) did not connect to TCP {self.host}:{self.port} "
                                           f"within {self.connect_timeout_s:g} s" + self._px4_log()) from None

    def _px4_log(self) -> str:
        """The tail of the log of the PX4 we started ('' for an external PX4)."""
        return self.process.log_note() if self.process is not None else ""

    def _emit(self, t_us: int, kind: str, message: str, data: dict[str, object] | None = None) -> None:
        self._events.append(Event(t_us, kind, message, data or {}))

    def _on_msg(self, m: Any) -> None:
        typ = m.get_type()
        if typ == "HEARTBEAT":
            self.px4_heartbeat = m
        elif typ == "COMMAND_LONG" and m.command == M.CMD_SET_MESSAGE_INTERVAL:
            self.requested_state_interval_us = m.param2 if int(m.param1) == 115 else self.requested_state_interval_us
        elif typ == "HIL_ACTUATOR_CONTROLS":
            self.controls = tuple(m.controls)
            self.armed = bool(m.mode & M.MODE_FLAG_SAFETY_ARMED)
            self._last_answer = (int(m.time_usec), time.monotonic())

    # ------------------------------------------------------------------ per step
    def step(self, obs: Observation) -> ActuatorCommand:
        """Send this step's sensors, wait (bounded) for PX4's actuator controls, map to rotor speeds."""
        link = self.link
        if link is None:
            raise AutopilotError("px4 autopilot: step() before reset()")
        if link.closed_by_peer.is_set():
            raise AutopilotError(f"PX4 closed the simulator connection (TCP {self.host}:{self.port})" + self._px4_log())
        t = obs.t_us + self.dt_us
        if self._t_last is not None and t <= self._t_last:
            raise AutopilotError(f"px4 autopilot: sim time went backwards ({t} <= {self._t_last} µs)")
        self._t_last = t
        self.steps += 1
        try:
            self._send_sensors(t, obs)
        except AutopilotError as exc:  # the connection broke while sending (PX4 died): say what PX4 said last
            raise AutopilotError(str(exc) + self._px4_log()) from None
        if not self.lockstep:
            self._boot_step(t, obs)
        else:
            self._lockstep_wait(t)
        mc = self.mission_client
        if mc is not None:
            mc.sim_time_us = obs.t_us
            self._poll_mission(obs.t_us)
        u = [_unit(self.controls[ch]) for ch in self.channels]  # the motor outputs, clamped once
        cmd = self._command(u)
        self._watch_saturation(obs, u)
        return cmd

    def _watch_saturation(self, obs: Observation, u: list[float]) -> None:
        """``cannot_take_off`` (see :mod:`vinecli.sitl.takeoff`) from the motor outputs ``u`` (0..1)."""
        if self._status.status is not RunStatus.RUNNING:
            return
        why = self._takeoff.update(obs.t_us, self.dt_us * 1e-6, self.armed, obs.truth.pos[2], obs.truth.vel[2], u)
        if why:
            st = self._status
            st.status = RunStatus.CANNOT_TAKE_OFF
            v, fill = self.ctx.vehicle, self.ctx.mission.tank_fill_l
            if fill is None:  # the mission's load: full unless it says
                fill = v.tank.capacity_l if v.tank is not None else 0.0
            st.detail = (f"{why} (weight {(v.dry_mass() + v.liquid_mass(fill)) * G0:.1f} N, "
                         f"max thrust {v.max_thrust():.1f} N)")
            self._emit(obs.t_us, "status", f"{st.status.value}: {st.detail}", {"status": st.status.value, "detail": st.detail})

    def _boot_step(self, t: int, obs: Observation) -> None:
        now = time.monotonic()
        if self._boot_wall0 is None:
            self._boot_wall0 = now - (self.steps - 1) * self.dt_us * 1e-6
        for m in self.link.drain():  # type: ignore[union-attr]
            self._on_msg(m)
            if m.get_type() == "HIL_ACTUATOR_CONTROLS":
                self.lockstep = True
        if self.lockstep:
            self._emit(obs.t_us, "px4", "lockstep started (first HIL_ACTUATOR_CONTROLS)",
                       {"boot_wall_s": round(now - self._boot_wall0, 3)})
            log.info("PX4 lockstep after %.2f s", now - self._boot_wall0)
            return
        if now - self._boot_wall0 > self.boot_timeout_s:
            raise AutopilotError(f"PX4 connected on TCP {self.host}:{self.port} but sent no HIL_ACTUATOR_CONTROLS within "
                                 f"{self.boot_timeout_s:g} s (check the airframe: PX4_SIM_MODEL=none_iris)")
        # pace at wall-clock rate while PX4 boots
        due = self._boot_wall0 + self.steps * self.dt_us * 1e-6
        if due > now:
            time.sleep(due - now)

    def _command(self, u: list[float]) -> ActuatorCommand:
        """Rotor speeds from the motor outputs ``u`` (0..1, one per rotor), the sprayer from its channel."""
        if not self.armed:
            return ActuatorCommand((0.0,) * len(self.channels), 0.0, False)
        span = self.w_max - self.w_min
        w = [self.w_min + ui * span for ui in u]
        return ActuatorCommand(tuple(w), _unit(self.controls[self.spray_ch]) * self.nozzle, True)

    def _send_sensors(self, t: int, obs: Observation) -> None:
        link = self.link
        assert link is not None
        mav = link.mav
        tr = obs.truth
        if self.hil_state:
            q = xyzw_to_wxyz(attitude_grid_to_ned_frd(tr.quat, self.gamma))
            p, qv, r = flu_to_frd(tr.omega_body)
            lat, lon, alt = self.ctx.origin.enu_to_geodetic_fast(*tr.pos)
            vn, ve, vd = grid_to_ned(tr.vel, self.gamma)
            sf = flu_to_frd(quat_rotate_inv(tr.quat, (tr.acc[0], tr.acc[1], tr.acc[2] + G0)))
            spd = min(65535, round(math.sqrt(vn * vn + ve * ve + vd * vd) * 100))
            link.send(mav.hil_state_quaternion_encode(
                t, q, p, qv, r, round(lat * 1e7), round(lon * 1e7), round(alt * 1000),
                _i16(vn * 100), _i16(ve * 100), _i16(vd * 100), spd, spd,
                _i16(sf[0] * 1000), _i16(sf[1] * 1000), _i16(sf[2] * 1000)))
        imu = obs.imu
        ax, ay, az = flu_to_frd(imu.accel_flu)
        gx, gy, gz = flu_to_frd(imu.gyro_flu)
        fields = M.FIELDS_ACCEL | M.FIELDS_GYRO  # mag and baro only when they have a new sample (as Gazebo)
        if obs.mag is not None:
            self._mag_frd = flu_to_frd(obs.mag.field_flu_gauss)
            fields |= M.FIELDS_MAG
        elif self._mag_frd is None:  # before the first magnetometer sample: the WMM field rotated into the body
            self._mag_frd = flu_to_frd(quat_rotate_inv(tr.quat, self.mag_world))
            fields |= M.FIELDS_MAG
        if obs.baro is not None:
            b = obs.baro
            self._baro = (b.pressure_pa / 100.0, b.temperature_c, b.altitude_m)
            fields |= M.FIELDS_BARO
        elif self._baro is None:
            from vinecli.flight.atmosphere import pressure_at, temperature_at

            alt = self.ctx.origin.alt + tr.pos[2]
            self._baro = (pressure_at(alt) / 100.0, temperature_at(alt) - 273.15, alt)
            fields |= M.FIELDS_BARO
        mx, my, mz = self._mag_frd
        p_hpa, temp_c, p_alt = self._baro
        link.send(mav.hil_sensor_encode(t, ax, ay, az, gx, gy, gz, mx, my, mz, p_hpa, 0.0, p_alt, temp_c, fields, 0))
        g = obs.gnss
        if g is not None:
            vn, ve, vd = grid_to_ned(g.vel_enu, self.gamma)
            gs = math.hypot(vn, ve)
            cog = 65535 if gs < 0.2 else round(math.degrees(math.atan2(ve, vn)) % 360.0 * 100) % 36000
            link.send(mav.hil_gps_encode(
                self.epoch_us + g.t_us, g.fix_type, round(g.lat_deg * 1e7), round(g.lon_deg * 1e7), round(g.alt_m * 1000),
                min(65535, round(g.eph_m * 100)), min(65535, round(g.epv_m * 100)), min(65535, round(gs * 100)),
                _i16(vn * 100), _i16(ve * 100), _i16(vd * 100), cog, min(255, g.satellites), 0, 0))
            self.hil_gps_sent += 1

    def _poll_mission(self, t_us: int) -> None:
        mc = self.mission_client
        for kind, msg, data in mc.drain_events():
            self._emit(t_us, kind, msg, data)
        if mc.error is not None:
            raise mc.error
        st = self._status
        st.mode = mc.mode_name
        st.phase_index = mc.phase_index
        if mc.finished is not None and st.status is RunStatus.RUNNING:
            st.status, st.detail = mc.finished
            self._emit(t_us, "status", f"{st.status.value}: {st.detail}", {"status": st.status.value, "detail": st.detail})

    def status(self) -> AutopilotStatus:
        """Mode (PX4 mode name), mission phase, and lockstep counters in ``extra``."""
        st = self._status
        ex = st.extra
        ex["px4_stalls"] = float(getattr(self, "stalls", 0))
        ex["px4_resyncs"] = float(getattr(self, "resyncs", 0))
        ex["px4_lockstep_recoveries"] = float(getattr(self, "recoveries", 0))
        ex["px4_lockstep_steps"] = float(getattr(self, "lockstep_steps", 0))
        ex["px4_armed"] = 1.0 if getattr(self, "armed", False) else 0.0
        if self.mission_client is not None:
            ex["px4_mission_seq"] = float(self.mission_client.current_seq)
            ex["px4_battery_warnings"] = float(self.mission_client.battery_warnings)
        return st

    def drain_events(self) -> list[Event]:
        """Events since the last call (connection, lockstep, mission progress, PX4 STATUSTEXT...)."""
        ev, self._events = self._events, []
        return ev

    def close(self) -> None:
        """Stop the mission thread, close the sockets, stop the PX4 we started. Idempotent."""
        if self._closed:
            return
        self._closed = True
        if self.mission_client is not None:
            self.mission_version = self.mission_client.version_msg
            self.mission_client.close()
            self.mission_client = None
        if self.link is not None:
            self.link.close()
        if self.process is not None:
            self.process.stop()
            from vinecli.sitl.identity import identity_from_message
            from vinecli.sitl.record import FirmwareRecord

            rec = FirmwareRecord(identity_from_message("PX4", self.mission_version, self.px4_bin))
            rec.files = self.process.keep(KEEP, rec.dir)
            rec.auditor = apply_audit  # PX4's own log: did its periodic work (battery, load monitor) run to the end?
            self.firmware_record = rec
            self.process.discard()
            self.process = None
        if self._instance_lock is not None:
            self._instance_lock.release()
            self._instance_lock = None


def _unit(u: float) -> float:
    """A PX4 actuator output clamped to [0, 1] (NaN -> 0)."""
    return 0.0 if not u > 0.0 else (1.0 if u > 1.0 else u)


def _i16(x: float) -> int:
    return max(-32767, min(32767, round(x))) if math.isfinite(x) else 0


__all__ = ["Px4SitlAutopilot"]
