"""The ground-station side of one ArduCopter run, stepped in simulated time by the lockstep.

:class:`ArdupilotClient` is called once per servo frame, while ArduPilot waits for the physics' answer
(:meth:`step`): it reads what ArduPilot sent (:class:`~vinecli.sitl.polled_link.PolledTcpLink`, no thread),
acts, and sends. Every deadline is simulated time, so the conversation is the same on a loaded machine.

**What it sees, and when.** ArduPilot consumes what vinecli sends at fixed points of its simulated clock
(its serial ports are read in its lockstep), but when its TCP output reaches vinecli's socket relative to
its UDP servo frames is the kernel's doing: acting on what happened to be polled made the same seed arm at
24 ms in one run and 28 ms in the other beside a CPU hog. The client reads through an
:class:`~vinecli.sitl.inbox.OrderedInbox`: every 5 frames it sends a TIMESYNC request (``ts1`` = the frame),
which ArduPilot answers from its main loop (``GCS_MAVLINK::handle_timesync``) in order with everything else
it writes on SERIAL0; what ArduPilot wrote before the answer to the marker of frame ``f`` is handed to the
client at frame ``f + 20`` (80 ms at 250 Hz; in flight ArduPilot's answer arrives 2-9 frames after the
request, while it boots up to 19). If the answer is not there then, the inbox waits for it on the socket
(up to 0.5 s): ArduPilot, blocked until the physics answers, has either written it already (the kernel
delivers it) or not handled the request yet (while it boots, before its MAVLink runs), and then the batch
goes out at the first frame after the answer; ``ardupilot_late_markers`` counts markers given up after 25 such frames. So the client
acts at frames fixed by ArduPilot's own output order: the boot, the parameter read-back, the uploads, the
arming and the end of the run happen at the same frame on every run.

Boot (:attr:`booted` once done): connect to SERIAL0 (TCP 5760 + 10 i), ask for AUTOPILOT_VERSION (the
firmware's identity) and the state messages, read back every parameter vinecli wrote into the run's
parameter file (:class:`~vinecli.sitl.params.ParamReadback`), wait for ArduPilot's pre-arm checks to
pass (SYS_STATUS health bit MAV_SYS_STATUS_PREARM_CHECK; its EKF needs ~40 s of simulated GNSS), upload
the mission and the fence. Flight (:meth:`start`): AUTO mode, arm (AUTO_OPTIONS 3 lets it take off),
then follow HEARTBEAT (mode, armed), MISSION_CURRENT, MISSION_ITEM_REACHED and EXTENDED_SYS_STATE. The
run is ``completed`` when ArduPilot reported the last item reached and is landed and disarmed; leaving
AUTO before that is a ``failsafe`` whose cause is ArduPilot's latest warning text.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from vinecli.autopilot.base import RunStatus
from vinecli.errors import AutopilotError, AutopilotTimeout
from vinecli.mavlink import px4modes as M
from vinecli.sitl.ardupilot.mission_plan import ArdupilotPlan
from vinecli.sitl.inbox import OrderedInbox
from vinecli.sitl.mission_upload import MissionUpload
from vinecli.sitl.params import ParamReadback
from vinecli.sitl.polled_link import PolledTcpLink, statustext

log = logging.getLogger(__name__)

#: ArduCopter flight modes (custom_mode)
COPTER_MODES = {0: "stabilize", 1: "acro", 2: "alt_hold", 3: "auto", 4: "guided", 5: "loiter", 6: "rtl", 7: "circle",
                9: "land", 11: "drift", 13: "sport", 14: "flip", 15: "autotune", 16: "poshold", 17: "brake",
                18: "throw", 19: "avoid_adsb", 20: "guided_nogps", 21: "smart_rtl", 22: "flowhold", 23: "follow",
                24: "zigzag", 25: "systemid", 26: "autorotate", 27: "auto_rtl", 28: "turtle"}
MODE_AUTO = 3
#: messages ArduPilot streams to vinecli (id -> interval µs): HEARTBEAT, SYS_STATUS, MISSION_CURRENT,
#: EXTENDED_SYS_STATE, BATTERY_STATUS, EKF_STATUS_REPORT
STREAMS = {0: 100_000, 1: 200_000, 42: 200_000, 245: 200_000, 147: 500_000, 193: 500_000}
#: EKF_STATUS_REPORT flags ArduCopter needs to arm for a mission (its "Need Position Estimate"): attitude,
#: horizontal and vertical velocity, absolute horizontal and vertical position; and not these
EKF_READY = 1 | 2 | 4 | 16 | 32
EKF_NOT_READY = 128 | 1024  # constant-position mode, uninitialised
#: GLOBAL_POSITION_INT, streamed at 10 Hz when the ground station sets segment rates in flight
GLOBAL_POSITION_INT = 33
SEVERITY_WARNING = 4
COMMAND_RESEND_US = 500_000
COMMAND_TIMEOUT_US = 3_000_000


@dataclass
class _Command:
    """One COMMAND_LONG waiting for its COMMAND_ACK (resent in simulated time)."""

    command: int
    params: tuple[float, ...]
    what: str
    sent_us: int
    first_us: int
    acked: Any = None


@dataclass
class FlightState:
    """What ArduPilot reported about the flight."""

    mode: str = "boot"
    armed: bool = False
    current_seq: int = 0
    max_seq: int = 0  # the furthest item the mission got to in this flight
    reached: set[int] = field(default_factory=set)
    landed_state: int = M.LANDED_UNDEFINED
    was_airborne: bool = False
    prearm_ok: bool = False
    ekf_ok: bool = False
    sys_status: Any = None
    battery: Any = None
    warnings: list[tuple[int, str]] = field(default_factory=list)  # (sim µs, text) severity <= WARNING
    last_text: str = ""
    battery_warnings: int = 0  # ArduPilot warnings (STATUSTEXT <= WARNING) about its battery


class ArdupilotClient:
    """See the module docstring. ``events`` collects (kind, message, data) for the run's event log."""

    def __init__(self, link: PolledTcpLink, plan: ArdupilotPlan, expected_params: dict[str, int | float], *,
                 target_system: int = 1, boot_timeout_us: int = 180_000_000,
                 alive: Callable[[], bool] | None = None) -> None:
        self.link, self.plan, self.target = link, plan, target_system
        self.inbox = OrderedInbox(link, alive=alive)
        self.boot_timeout_us = boot_timeout_us
        self.state = FlightState()
        self.readback = ParamReadback(expected_params, target_system, firmware="ArduPilot")
        self.uploads = [MissionUpload(plan.items, M.MAV_MISSION_TYPE_MISSION, target_system, firmware="ArduPilot")]
        if plan.fence:
            self.uploads.append(MissionUpload(plan.fence, M.MAV_MISSION_TYPE_FENCE, target_system, firmware="ArduPilot"))
        self.version_msg: Any = None
        self.events: list[tuple[str, str, dict[str, object]]] = []
        self.finished: tuple[RunStatus, str] | None = None
        self.phase_index = 0
        self._connected_us: int | None = None
        self._upload_i = -1
        self._command: _Command | None = None
        self._queue: list[tuple[int, tuple[float, ...], str]] = []
        self._hb_us = -10**12
        self.started = False
        self.in_mission = False

    # ------------------------------------------------------------------ per frame
    @property
    def booted(self) -> bool:
        return self.readback.done and self.ready_to_arm and self._upload_i >= len(self.uploads)

    @property
    def ready_to_arm(self) -> bool:
        """ArduPilot's pre-arm checks pass and its EKF has an absolute position."""
        return self.state.prearm_ok and self.state.ekf_ok

    def step(self, t_us: int) -> None:
        """Handle what arrived, then act; ArduPilot is blocked until the physics answers (module docstring)."""
        link = self.link
        if not link.connected:
            if link.try_connect():
                self._on_connect(t_us)
            return
        for m in self.inbox.frame():
            self._handle(m, t_us)
        if link.closed_by_peer:
            raise AutopilotError(f"ArduPilot closed the MAVLink link (TCP {link.host}:{link.port})")
        if t_us - self._hb_us >= 1_000_000:
            self._hb_us = t_us
            link.send(link.mav.heartbeat_encode(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, M.MAV_STATE_ACTIVE))
        self._command_tick(t_us)
        if not self.booted:
            self._boot_tick(t_us)
        elif self.started:
            self._monitor(t_us)

    def start(self, t_us: int) -> None:
        """Fly: AUTO mode, then arm (ArduPilot takes off with AUTO_OPTIONS 3)."""
        self.started = True
        self._queue += [(M.CMD_DO_SET_MODE, (1.0, float(MODE_AUTO)), "set AUTO mode"),
                        (M.CMD_COMPONENT_ARM_DISARM, (1.0,), "arm")]
        self._command_tick(t_us)

    def _on_connect(self, t_us: int) -> None:
        self._connected_us = t_us
        self.events.append(("ardupilot_link", f"MAVLink link up on TCP {self.link.host}:{self.link.port}", {}))
        streams = {**STREAMS, **({GLOBAL_POSITION_INT: 100_000} if self.plan.pump_rates is not None else {})}
        for msg_id, interval in streams.items():
            self._queue.append((M.CMD_SET_MESSAGE_INTERVAL, (float(msg_id), float(interval)), f"stream {msg_id}"))
        self._queue.append((M.CMD_REQUEST_MESSAGE, (148.0,), "AUTOPILOT_VERSION"))

    def _boot_tick(self, t_us: int) -> None:
        if self._connected_us is not None and t_us - self._connected_us > self.boot_timeout_us:
            said = f" (ArduPilot: {self.state.last_text!r})" if self.state.last_text else ""
            what = ("read back its parameters" if not self.readback.done else
                    "pass its pre-arm checks" if not self.state.prearm_ok else
                    "have a position estimate (EKF)" if not self.state.ekf_ok else "take the mission")
            raise AutopilotTimeout(f"ArduPilot did not {what} within {self.boot_timeout_us / 1e6:g} s of "
                                   f"simulated time{said}")
        self.readback.tick(self.link, t_us)
        if not (self.readback.done and self.ready_to_arm):
            return
        if self._upload_i < 0:
            self.events.append(("ardupilot_params", f"{len(self.readback.read)} parameters read back as written",
                                {"count": len(self.readback.read)}))
            self.events.append(("ardupilot_ready", "ArduPilot pre-arm checks pass, EKF has a position", {}))
            self._next_upload(t_us)
        elif self._upload_i < len(self.uploads):
            up = self.uploads[self._upload_i]
            up.tick(self.link, t_us)
            if up.done:
                self.events.append(("mission_uploaded", f"{up.what} uploaded ({len(up.items)} items)",
                                    {"mission_type": up.mission_type, "count": len(up.items)}))
                self._next_upload(t_us)

    def _next_upload(self, t_us: int) -> None:
        self._upload_i += 1
        if self._upload_i < len(self.uploads):
            self.uploads[self._upload_i].start(self.link, t_us)

    # ------------------------------------------------------------------ commands
    def _command_tick(self, t_us: int) -> None:
        c = self._command
        if c is not None and c.acked is None:
            if t_us - c.first_us > COMMAND_TIMEOUT_US:
                raise AutopilotTimeout(f"ArduPilot did not acknowledge the command to {c.what} within "
                                       f"{COMMAND_TIMEOUT_US / 1e6:g} s of simulated time{self._says()}")
            if t_us - c.sent_us >= COMMAND_RESEND_US:
                c.sent_us = t_us
                self._send_command(c, confirmation=1)
            return
        if self._queue:
            cmd, params, what = self._queue.pop(0)
            self._command = _Command(cmd, params, what, t_us, t_us)
            self._send_command(self._command)

    def _send_command(self, c: _Command, confirmation: int = 0) -> None:
        p = list(c.params) + [0.0] * (7 - len(c.params))
        self.link.send(self.link.mav.command_long_encode(self.target, 1, c.command, confirmation, *p))

    def _on_ack(self, m: Any) -> None:
        c = self._command
        if c is None or m.command != c.command or c.acked is not None:
            return
        c.acked = m
        if m.result != M.MAV_RESULT_ACCEPTED and c.command in (M.CMD_DO_SET_MODE, M.CMD_COMPONENT_ARM_DISARM):
            raise AutopilotError(f"ArduPilot refused to {c.what}: {M.MAV_RESULT_NAMES.get(m.result, m.result)}"
                                 + self._says())
        if c.command == M.CMD_COMPONENT_ARM_DISARM:
            self.events.append(("mission_start", "armed in AUTO: mission started", {}))

    def _says(self) -> str:
        st = self.state
        said = st.warnings[-1][1] if st.warnings else st.last_text
        return f" (ArduPilot: {said!r})" if said else ""

    # ------------------------------------------------------------------ messages
    def _handle(self, m: Any, t_us: int) -> None:
        if m.get_srcSystem() != self.target:
            return
        typ = m.get_type()
        self.readback.on_message(m)
        if 0 <= self._upload_i < len(self.uploads):
            self.uploads[self._upload_i].on_message(m, self.link, t_us)
        st = self.state
        if typ == "HEARTBEAT" and m.get_srcComponent() == 1:
            self._on_heartbeat(m, t_us)
        elif typ == "COMMAND_ACK":
            self._on_ack(m)
        elif typ == "AUTOPILOT_VERSION":
            self.version_msg = m
        elif typ == "STATUSTEXT":
            text = statustext(m)
            st.last_text = text
            self.events.append(("ardupilot_statustext", text, {"severity": int(m.severity)}))
            if int(m.severity) <= SEVERITY_WARNING:
                st.warnings = [*st.warnings[-9:], (t_us, text)]
                st.battery_warnings += "batt" in text.lower()
        elif typ == "SYS_STATUS":
            st.sys_status = m
            st.prearm_ok = bool(m.onboard_control_sensors_health & M.SENSOR_PREARM_CHECK)
        elif typ == "BATTERY_STATUS":
            st.battery = m
        elif typ == "EKF_STATUS_REPORT":
            st.ekf_ok = (m.flags & EKF_READY) == EKF_READY and not m.flags & EKF_NOT_READY
        elif typ == "MISSION_CURRENT":
            if m.seq != st.current_seq:
                st.current_seq = m.seq
                if self.in_mission and m.seq > st.max_seq:  # forward only: ArduPilot rewinds to item 1 on disarm
                    st.max_seq = m.seq
                    self._set_phase(m.seq)
        elif typ == "MISSION_ITEM_REACHED" and m.seq not in st.reached:
            st.reached.add(m.seq)
            self.events.append(("mission_item_reached", f"item {m.seq} reached", {"seq": int(m.seq)}))
        elif typ == "GLOBAL_POSITION_INT" and self.plan.pump_rates is not None and self.in_mission:
            self._pump_rate(m, t_us)
        elif typ == "EXTENDED_SYS_STATE" and m.landed_state != st.landed_state:
            st.landed_state = m.landed_state
            names = {1: "on_ground", 2: "in_air", 3: "takeoff", 4: "landing"}
            self.events.append(("landed_state", names.get(m.landed_state, "undefined"),
                                {"landed_state": int(m.landed_state)}))
            st.was_airborne |= m.landed_state == M.LANDED_IN_AIR

    def _on_heartbeat(self, m: Any, t_us: int) -> None:
        st = self.state
        armed = bool(m.base_mode & M.MODE_FLAG_SAFETY_ARMED)
        name = COPTER_MODES.get(int(m.custom_mode), f"mode{m.custom_mode}")
        if name != st.mode:
            self.events.append(("mode", name, {"mode": name, "previous": st.mode}))
            st.mode = name
            self._check_mode(name, t_us)
        if armed != st.armed:
            st.armed = armed
            self.events.append(("arming", "armed" if armed else "disarmed", {"armed": armed}))

    def _pump_rate(self, m: Any, t_us: int) -> None:
        """Segment rates: SPRAY_PUMP_RATE of the next piece when the vehicle reaches it (:mod:`.pump_rates`)."""
        sched, frame = self.plan.pump_rates, self.plan.frame
        assert sched is not None and frame is not None
        x, y = frame.e7_to_world(int(m.lat), int(m.lon))
        vx, vy = frame.ned_velocity_to_world(m.vx * 0.01, m.vy * 0.01)
        c = sched.due(t_us * 1e-6, x, y, vx, vy)
        if c is None:
            return
        self.link.send(self.link.mav.param_set_encode(self.target, 1, b"SPRAY_PUMP_RATE", float(c.pump_rate), 9))
        self.events.append(("pump_rate_set", f"SPRAY_PUMP_RATE {c.pump_rate:g} %/(m/s) for {c.rate_lpha:.1f} L/ha",
                            {"pump_rate": c.pump_rate, "rate_lpha": round(c.rate_lpha, 3), "at_enu": [round(x, 3), round(y, 3)],
                             "piece_enu": [round(c.x, 3), round(c.y, 3)], "change": sched.next_i - 1}))

    def _set_phase(self, seq: int) -> None:
        poi = self.plan.phase_of_item
        if 0 <= seq < len(poi) and poi[seq] >= 0 and poi[seq] != self.phase_index:
            self.phase_index = poi[seq]
            self.events.append(("phase", f"phase {self.phase_index} (item {seq})", {"index": self.phase_index, "seq": seq}))

    # ------------------------------------------------------------------ the flight
    def mission_done(self) -> bool:
        """ArduPilot reported the last item done: MISSION_ITEM_REACHED for it, or, for a last landing item
        (NAV_LAND, RTL), the mission executing it when ArduCopter disarmed on the ground (its way of
        completing a landing: ModeAuto::verify_land disarms and holds the mission there)."""
        last = len(self.plan.items) - 1
        st = self.state
        if last in st.reached:
            return True
        return (self.plan.lands and st.max_seq == last and st.was_airborne and not st.armed
                and st.landed_state == M.LANDED_ON_GROUND)

    def _check_mode(self, name: str, t_us: int) -> None:
        """ArduPilot leaving AUTO before the mission is done (fence, battery failsafe...) ends the run."""
        if not self.started or self.finished is not None:
            return
        if name == "auto":
            self.in_mission = True
            return
        if not self.in_mission or self.mission_done():
            return
        recent = [t for w, t in self.state.warnings if t_us - w < 5_000_000]
        cause = "; ".join(dict.fromkeys(recent)) or f"mode changed from auto to {name}"
        self.events.append(("failsafe", f"ArduPilot left the mission: {cause} -> {name}",
                            {"cause": cause, "action": name, "mode": name, "seq": self.state.current_seq}))
        self.finished = (RunStatus.FAILSAFE, f"ArduPilot failsafe: {cause} -> {name} "
                                             f"(mission item {self.state.current_seq})")

    def _monitor(self, t_us: int) -> None:
        st = self.state
        if self.finished is not None:
            return
        if self.plan.lands:
            if self.mission_done() and st.was_airborne and st.landed_state == M.LANDED_ON_GROUND and not st.armed:
                self.finished = (RunStatus.COMPLETED, f"ArduPilot mission completed (item {st.max_seq} of "
                                                      f"{len(self.plan.items) - 1}), landed and disarmed")
        elif self.mission_done():
            self.finished = (RunStatus.COMPLETED, "ArduPilot mission completed")


__all__ = ["COPTER_MODES", "ArdupilotClient", "FlightState"]
