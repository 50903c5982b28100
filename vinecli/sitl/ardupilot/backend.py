"""ArduCopter SITL backend: vinecli is the physics of ArduPilot's JSON SITL backend, in lockstep.

Per physics step (:meth:`ArdupilotSitlAutopilot.step`, ArduPilot waits for each answer):

1. answer ArduPilot's pending servo frame with the state this step reached (:mod:`.json_link`): gyro
   and specific force from vinecli's rigid body (body FRD; ArduPilot adds its own IMU noise), position
   and velocity NED from its home, attitude quaternion; first, every MAVLink byte sent so far must be
   in ArduPilot's socket (:mod:`vinecli.sitl.delivery`: ArduPilot reads its port right after the answer,
   and on a loaded machine the kernel can deliver the answer before earlier TCP bytes);
   ``ardupilot_delivery_waits`` counts answers that waited for that, ``ardupilot_undelivered`` the ones
   sent without it (bytes still undelivered after ``DELIVERY_WAIT_S``; 0 on a run that repeats);
2. receive ArduPilot's next servo frame: its outputs for the step that starts now;
3. with ArduPilot blocked again, read and answer its MAVLink (:class:`.client.ArdupilotClient`) and feed
   it the battery vinecli simulates (SIM_BATT_VOLTAGE and the current sensor's offset, every 0.1 s);
4. rotor speeds from the motor outputs (w = w_min + u (w_max - w_min), u = (PWM - 1000) / 1000; 0 at or
   below 1000 µs), the nozzle flow from AC_Sprayer's pump output (flow = u_pump x the pump's maximum).

Boot (first step): ArduPilot starts on a free instance with the run's parameter file; the vehicle rests
at its spawn pose while ArduPilot boots, reads back its parameters, converges its EKF and passes its
pre-arm checks, and takes the mission. That time is the firmware's (``ardupilot_boot_s``): the run's
clock starts at 0 when ArduPilot is ready, as a drone is powered up and waits for its GNSS before the
operator starts the mission. Every wait is the lockstep or simulated time; wall-clock limits only
detect a firmware that died or hung (no servo frame for ``frame_timeout_s``; 10 s when all it sends on the
servo-frame port is something else): an error, exit 3.
"""

from __future__ import annotations

import logging
import math
import signal
from typing import Any

from vinecli.autopilot.base import AutopilotContext, AutopilotStatus, RunStatus
from vinecli.constants import STANDARD_GRAVITY
from vinecli.errors import AutopilotError, InputError
from vinecli.frames import attitude_grid_to_ned_frd, flu_to_frd, grid_to_ned, quat_rotate_inv, xyzw_to_wxyz
from vinecli.sitl.ardupilot.client import ArdupilotClient
from vinecli.sitl.ardupilot.json_link import JSON_PORT_BASE, JsonPhysicsLink, ServoFrame, state_line, timestamp_s
from vinecli.sitl.ardupilot.mission_plan import ArdupilotPlan, home_frame, plan_for
from vinecli.sitl.ardupilot.params import pump_fraction, sprayer_params, vehicle_params
from vinecli.sitl.ardupilot.process import SERIAL0_PORT_BASE, ArdupilotProcess, reserve_instance
from vinecli.sitl.converter import pump_max_flow_lps, takeoff_mass_kg
from vinecli.sitl.dose_follow import follow_event
from vinecli.sitl.identity import identity_from_message
from vinecli.sitl.polled_link import PolledTcpLink
from vinecli.sitl.record import FirmwareRecord
from vinecli.sitl.takeoff import TakeoffWatch
from vinecli.types import ActuatorCommand, Event, Observation, RigidState

log = logging.getLogger(__name__)

BATTERY_PERIOD_US = 100_000
#: wall seconds an answer waits for the kernel to deliver the MAVLink bytes sent before it (milliseconds under load)
DELIVERY_WAIT_S = 2.0
#: parameters vinecli sets while flying (the battery), not in the parameter file
#: a firmware that has sent this many datagrams on the servo-frame port and not one servo frame is not ArduCopter on
#: the JSON backend (a real one sends its first frame as it starts): it is named after GARBAGE_ONLY_WAIT_S wall
#: seconds instead of the whole frame timeout
GARBAGE_ONLY_DATAGRAMS = 100
GARBAGE_ONLY_WAIT_S = 10.0
LIVE_PARAMS = ("SIM_BATT_VOLTAGE", "BATT_AMP_OFFSET")
KEEP = ("logs/*.BIN", "ardupilot.log", "vinecli.parm")


class ArdupilotSitlAutopilot:
    """Autopilot backend driving a real ArduCopter SITL (see the module docstring).

    Options: ``ardupilot_bin`` (the ``arducopter`` SITL binary; required), ``instance`` (ArduPilot ``-I``;
    default a free one in 10-99), ``host`` (loopback), ``workdir`` (keep ArduPilot's working directory
    there instead of a temporary one), ``frame_timeout_s`` (wall seconds without a servo frame before the
    firmware counts as hung, default 30), ``boot_timeout_s`` (simulated seconds for ArduPilot to become
    ready, default 180), ``cannot_takeoff_s`` (default the vehicle's ``control.cannot_takeoff_s``).
    """

    name = "ardupilot"

    def __init__(self, *, ardupilot_bin: str | None = None, instance: int | None = None, host: str = "127.0.0.1",
                 workdir: str | None = None, frame_timeout_s: float = 30.0, boot_timeout_s: float = 180.0,
                 cannot_takeoff_s: float | None = None, **opts: Any) -> None:
        if opts:
            raise InputError(f"ardupilot autopilot: unknown option(s) {', '.join(sorted(opts))}")
        if ardupilot_bin is None:
            raise InputError("--autopilot ardupilot needs --ardupilot-bin PATH (an ArduCopter SITL binary, e.g. "
                             "bin/arducopter of an ArduCopter SITL build; docs/firmware-protocols.md)")
        if instance is not None and not 0 <= instance <= 99:
            raise InputError(f"ardupilot autopilot: instance {instance} out of range 0..99")
        if not (frame_timeout_s > 0 and boot_timeout_s > 0):
            raise InputError("ardupilot autopilot: frame_timeout_s and boot_timeout_s must be > 0")
        self.bin, self.host, self.workdir = ardupilot_bin, host, workdir
        self.instance = instance
        self.frame_timeout_s, self.boot_timeout_s = frame_timeout_s, boot_timeout_s
        self.cannot_takeoff_s = cannot_takeoff_s
        self.process: ArdupilotProcess | None = None
        self.json: JsonPhysicsLink | None = None
        self.client: ArdupilotClient | None = None
        self.firmware_record: FirmwareRecord | None = None
        self._lock: Any = None
        self._events: list[Event] = []
        self._status = AutopilotStatus(mode="boot", phase_index=0)
        self._closed = False

    # ------------------------------------------------------------------ set-up
    def reset(self, ctx: AutopilotContext) -> None:
        """Plan the mission and the parameters (SpecError before anything starts), then start ArduPilot."""
        self.ctx = ctx
        v = ctx.vehicle
        self.frame = home_frame(ctx)
        self.plan: ArdupilotPlan = plan_for(ctx, self.frame)
        self.dt_us = ctx.physics_dt_us
        params = vehicle_params(v, physics_rate_hz=1e6 / self.dt_us, mass_kg=takeoff_mass_kg(ctx), g=STANDARD_GRAVITY)
        self.pump_ch = v.px4.sprayer_channel
        self.nozzle = pump_max_flow_lps(v)  # the pump model's maximum: the firmware's pump output is a duty of it
        if self.plan.sprayer is not None:
            params.update(sprayer_params(self.plan.sprayer, v.sprayer, pump_max_flow_lps=self.nozzle,
                                         pump_channel=self.pump_ch))
        params.update(self.plan.params)
        self.params = params
        self.w_min, self.w_max = v.motor.w_min_armed, v.motor.w_max
        self.n = v.n_rotors
        first = ctx.mission.phases[0]
        self._takeoff = TakeoffWatch(self.cannot_takeoff_s or v.control.cannot_takeoff_s,
                                     getattr(first, "timeout_s", None) if first.type == "takeoff" else None,
                                     firmware="ArduPilot")
        self.answers = 0
        self.steps = 0
        self.stalls = 0
        self.resends = 0
        self.delivery_waits = 0  # answers that waited for the kernel to deliver MAVLink bytes to ArduPilot
        self.undelivered = 0  # answers sent with MAVLink bytes still undelivered after DELIVERY_WAIT_S
        self.boot_s = 0.0
        self._last_count: int | None = None
        self._frame: ServoFrame | None = None
        self._truth: RigidState | None = None  # the state of the last answer
        self._answered: int | None = None  # the count of the last frame answered
        self._batt_us = -10**12
        self._booted = False
        self._stopping = False
        self._closed = False
        try:
            self._start()
        except BaseException:
            self.close()  # its record kept: close() acts once
            raise

    def _start(self) -> None:
        if self.instance is None:
            self._lock = reserve_instance()
            self.instance = self._lock.instance
        i = self.instance
        fr = self.frame
        yaw = 0.0
        self.process = ArdupilotProcess(self.bin, i, home=(fr.lat_e7 * 1e-7, fr.lng_e7 * 1e-7, fr.alt_m, yaw),
                                        params=self.params, workdir=self.workdir, sim_host=self.host)
        self.json = JsonPhysicsLink(self.host, JSON_PORT_BASE + 10 * i)
        link = PolledTcpLink(self.host, SERIAL0_PORT_BASE + 10 * i, name="ArduPilot")
        self.client = ArdupilotClient(link, self.plan, self.params, boot_timeout_us=int(self.boot_timeout_s * 1e6),
                                      alive=self.process.alive)
        self.process.start()
        self._emit(0, "ardupilot_process", f"ArduPilot started: instance {i}, pid {self.process.pid}",
                   {"instance": i, "pid": self.process.pid, "workdir": str(self.process.workdir)})

    # ------------------------------------------------------------------ per step
    def step(self, obs: Observation) -> ActuatorCommand:
        """Answer ArduPilot with this step's state, take its next outputs (module docstring)."""
        if self.client is None:
            raise AutopilotError("ardupilot autopilot: step() before reset()")
        if not self._booted:
            frame = self._boot(obs)
        elif self._stopping:
            frame = self._next_frame()
        else:
            self._answer(obs.truth)
            frame = self._next_frame()
            self._converse(obs)
        self.steps += 1
        u = [_unit(frame.pwm[ch]) for ch in range(self.n)]
        self._watch_takeoff(obs, u)
        if self.client.state.armed or any(x > 0.0 for x in u):
            w = tuple(self.w_min + x * (self.w_max - self.w_min) if frame.pwm[ch] > 1000 else 0.0
                      for ch, x in enumerate(u))
        else:
            w = (0.0,) * self.n
        flow = pump_fraction(frame.pwm[self.pump_ch]) * self.nozzle if self.pump_ch < len(frame.pwm) else 0.0
        return ActuatorCommand(w, flow, self.client.state.armed)

    def _boot(self, obs: Observation) -> ServoFrame:
        """The first step: ArduPilot boots against the vehicle at rest until it is ready to fly."""
        client = self.client
        assert client is not None
        stop = self.ctx.should_stop
        while True:
            if self._frame is not None and stop is not None and self.answers % 250 == 0 and stop():
                return self._frame  # not booted: the loop ends the run as interrupted, close() stops ArduPilot
            frame = self._next_frame()
            if self._stopping:
                return frame
            self._converse(obs)
            if client.booted:
                break
            self._answer(obs.truth)
        self._booted = True
        self.boot_s = self.answers * self.dt_us * 1e-6
        if client.version_msg is not None:
            ident = identity_from_message("ArduCopter", client.version_msg, self.bin)
            self._emit(obs.t_us, "firmware", f"ArduCopter {ident.version} ({ident.git_hash})", ident.to_dict())
        self._emit(obs.t_us, "ardupilot", f"ArduPilot ready after {self.boot_s:.1f} s of simulated boot",
                   {"boot_s": round(self.boot_s, 3), "frame_rate_hz": frame.rate_hz})
        rates = self.plan.pump_rates
        if rates is not None and (said := follow_event("ardupilot", self.plan.rate_paths, lead_s=rates.lead_s)):
            self._emit(obs.t_us, *said)  # segment rates: what ArduPilot does with them
        client.start(self._fw_us())
        return frame

    def _fw_us(self) -> int:
        """The firmware's clock: one physics step per answer."""
        return self.answers * self.dt_us

    def _answer(self, tr: RigidState) -> None:
        """The JSON answer to the pending frame: the state after one more physics step."""
        assert self.json is not None
        self._truth = tr
        line = self._state_line(tr)
        self._deliver_mavlink()
        self.json.answer(line)
        self._answered = self._last_count

    def _state_line(self, tr: RigidState) -> bytes:
        """The JSON line of state ``tr`` one physics step after the last answer (counts the answer)."""
        self.answers += 1
        hx, hy, hz = self.frame.home_enu
        gamma = self.ctx.origin.convergence_rad  # world (CRS grid) -> true north
        p = grid_to_ned((tr.pos[0] - hx, tr.pos[1] - hy, tr.pos[2] - hz), gamma)
        sf = flu_to_frd(quat_rotate_inv(tr.quat, (tr.acc[0], tr.acc[1], tr.acc[2] + STANDARD_GRAVITY)))
        q = xyzw_to_wxyz(attitude_grid_to_ned_frd(tr.quat, gamma))
        return state_line(timestamp_s(self.answers, self.dt_us), flu_to_frd(tr.omega_body), sf, p,
                          grid_to_ned(tr.vel, gamma), q)

    def _deliver_mavlink(self) -> None:
        """Before ArduPilot's clock moves: every MAVLink byte sent is in its socket (:mod:`vinecli.sitl.delivery`),
        so it reads them at its next port read on every run, however late the kernel delivered them."""
        link = self.client.link if self.client is not None else None
        if link is None or not link.connected:
            return
        done = link.wait_received(DELIVERY_WAIT_S)
        if done is False:
            self.delivery_waits += 1
        elif done is None and link.receipt.available:
            self.undelivered += 1

    def _next_frame(self) -> ServoFrame:
        """ArduPilot's next servo frame (its resends skipped); AutopilotError if it died, hung or sends no servo
        frames (garbage on its port); the last frame again when the run is asked to stop meanwhile (the loop then
        ends the run as interrupted: a SIGTERM never waits for :attr:`frame_timeout_s`)."""
        assert self.json is not None and self.process is not None
        waited = 0.0
        stop = self.ctx.should_stop
        while True:
            frame = None if self._stopping else self.json.recv_frame(0.5)
            if frame is None:
                waited += 0.5
                if not self._stopping and not self.process.alive():
                    raise AutopilotError(self._exited())
                if self._stopping or (stop is not None and stop()):
                    self._stopping = True  # the outputs held until the loop ends the run (within 0.1 s simulated)
                    return self._frame or ServoFrame(0, -1, (0,) * 16)
                garbage_only = self.json.frames == 0 and self.json.garbage >= GARBAGE_ONLY_DATAGRAMS
                if waited >= self.frame_timeout_s or (garbage_only and waited >= GARBAGE_ONLY_WAIT_S):
                    junk = (f", {self.json.garbage} datagrams that are not servo frames (is it ArduCopter SITL on the "
                            "JSON backend?)" if self.json.garbage else "")
                    raise AutopilotError(f"ArduPilot sent no servo frame for {waited:.0f} s (hung{junk})" + self._log())
                continue
            last = self._last_count
            if last is not None and frame.count == last:
                self.resends += 1  # ArduPilot waited ~1 s of wall time for an answer already sent: same frame
                continue
            if last is not None and frame.count < last:
                raise AutopilotError(f"ArduPilot restarted (servo frame count {frame.count} after {last})" + self._log())
            if last is not None and frame.count != last + 1:
                self.stalls += frame.count - last - 1
            self._last_count = frame.count
            self._frame = frame
            return frame

    def _converse(self, obs: Observation) -> None:
        """MAVLink while ArduPilot waits: the client, then the battery every 0.1 s of simulated time."""
        client = self.client
        assert client is not None
        t = self._fw_us()
        try:
            client.step(t)
        except AutopilotError:
            if self.process is not None and not self.process.alive():  # the cause, not its symptom
                raise AutopilotError(self._exited()) from None
            raise
        if client.link.connected and t - self._batt_us >= BATTERY_PERIOD_US and math.isfinite(obs.battery_voltage_v):
            self._batt_us = t
            link = client.link
            current = obs.battery_current_a if math.isfinite(obs.battery_current_a) else 0.0
            link.send(link.mav.param_set_encode(1, 1, b"SIM_BATT_VOLTAGE", float(obs.battery_voltage_v), 9))
            link.send(link.mav.param_set_encode(1, 1, b"BATT_AMP_OFFSET", -float(current), 9))
        for kind, msg, data in client.events:
            self._emit(obs.t_us, kind, msg, data)
        client.events.clear()
        st = self._status
        st.mode = client.state.mode
        st.phase_index = client.phase_index
        if client.finished is not None and st.status is RunStatus.RUNNING:
            st.status, st.detail = client.finished
            self._emit(obs.t_us, "status", f"{st.status.value}: {st.detail}", {"status": st.status.value, "detail": st.detail})

    def _watch_takeoff(self, obs: Observation, u: list[float]) -> None:
        if self._status.status is not RunStatus.RUNNING:
            return
        why = self._takeoff.update(obs.t_us, self.dt_us * 1e-6, self.client.state.armed if self.client else False,
                                   obs.truth.pos[2], obs.truth.vel[2], u)
        if why:
            st = self._status
            st.status = RunStatus.CANNOT_TAKE_OFF
            st.detail = f"{why} (weight {takeoff_mass_kg(self.ctx) * STANDARD_GRAVITY:.1f} N, " \
                        f"max thrust {self.ctx.vehicle.max_thrust():.1f} N)"
            self._emit(obs.t_us, "status", f"{st.status.value}: {st.detail}", {"status": st.status.value, "detail": st.detail})

    def _exited(self) -> str:
        """Why the run ends when ArduPilot is gone: its exit code or signal, its clock, its last words."""
        code = self.process.proc.returncode if self.process is not None and self.process.proc is not None else None
        how = f"killed by {signal.Signals(-code).name}" if code is not None and code < 0 else f"code {code}"
        when = (f"at {self.steps * self.dt_us * 1e-6:.2f} s of the run" if self._booted else
                f"while booting ({self._fw_us() * 1e-6:.1f} s of its clock)")
        return f"ArduPilot exited ({how}) {when}" + self._log()

    def _log(self) -> str:
        return self.process.log_note() if self.process is not None else ""

    def _emit(self, t_us: int, kind: str, message: str, data: dict[str, object] | None = None) -> None:
        self._events.append(Event(t_us, kind, message, data or {}))

    # ------------------------------------------------------------------ interface
    def status(self) -> AutopilotStatus:
        """Mode (ArduCopter mode name), mission phase and the lockstep counters in ``extra``."""
        st = self._status
        ex = st.extra
        ex["ardupilot_stalls"] = float(getattr(self, "stalls", 0))
        ex["ardupilot_lockstep_steps"] = float(getattr(self, "steps", 0))
        ex["ardupilot_resends"] = float(getattr(self, "resends", 0))
        ex["ardupilot_delivery_waits"] = float(getattr(self, "delivery_waits", 0))
        ex["ardupilot_undelivered"] = float(getattr(self, "undelivered", 0))
        ex["ardupilot_boot_s"] = float(getattr(self, "boot_s", 0.0))
        if self.client is not None:
            ex["ardupilot_armed"] = 1.0 if self.client.state.armed else 0.0
            ex["ardupilot_mission_seq"] = float(self.client.state.max_seq)
            ex["ardupilot_battery_warnings"] = float(self.client.state.battery_warnings)
            inbox = self.client.inbox
            ex["ardupilot_late_markers"] = float(inbox.late)
            ex["ardupilot_postponed_frames"] = float(inbox.postponed)
        return st

    def drain_events(self) -> list[Event]:
        ev, self._events = self._events, []
        return ev

    def _answer_while_stopping(self) -> None:
        """While ArduPilot shuts down: answer each frame not answered yet (the one the run ended on first, at once),
        the last state one step later each time: ArduPilot only sees the SIGTERM in its main loop, which runs only
        as its clock moves (measured: a frame left unanswered kept it from exiting until the SIGKILL 3 s later)."""
        if self.json is None or self._truth is None:
            return
        if self._last_count is None or self._answered == self._last_count:
            frame = self.json.recv_frame(0.05)
            if frame is None or frame.count == self._answered:
                return
            self._last_count = frame.count
        self._answered = self._last_count
        self.json.answer(self._state_line(self._truth))

    def close(self) -> None:
        """Stop ArduPilot (SIGTERM, answering its frames so it can exit and close its log; SIGKILL after 3 s),
        keep its log, console output and parameter file (:attr:`firmware_record`), free the instance."""
        if self._closed:
            return
        self._closed = True
        proc = self.process
        if proc is not None:
            proc.stop(timeout_s=3.0, while_waiting=self._answer_while_stopping)
            client = self.client
            ident = identity_from_message("ArduCopter", client.version_msg if client else None, self.bin)
            rec = FirmwareRecord(ident)
            rec.files = proc.keep(KEEP, rec.dir)
            self.firmware_record = rec
            proc.discard()
            self.process = None
        if self.client is not None:
            self.client.link.close()
        if self.json is not None:
            self.json.close()
        if self._lock is not None:
            self._lock.release()
            self._lock = None


def _unit(pwm: int) -> float:
    """A motor output 0..1 from its PWM (1000-2000 µs)."""
    return 0.0 if pwm <= 1000 else (1.0 if pwm >= 2000 else (pwm - 1000) / 1000.0)


__all__ = ["ArdupilotSitlAutopilot"]
