"""Mission control of PX4 over its API/offboard MAVLink link (PX4 sends to UDP 14540+i).

:class:`Px4MissionClient` runs in a **background thread** so the lockstep loop never blocks:
``step()`` of :class:`~vinecli.sitl.px4.backend.Px4SitlAutopilot` only reads the client's
state (mode, current item, events, error, finished). Sequence, each with a wall-clock timeout
(the simulation keeps stepping meanwhile):

1. bind UDP ``host:api_port`` (before PX4 boots) and wait for PX4's HEARTBEAT (autopilot 12);
2. PARAM_SET the mission's parameters (MIS_TAKEOFF_ALT, RTL_RETURN_ALT, GF_*, the sprayer
   output function ``PWM_MAIN_FUNCn`` = 301 "Peripheral via Actuator Set 1"), each confirmed by
   PARAM_VALUE;
3. upload the mission (mission_type 0) and the geofence (mission_type 1) with MISSION_COUNT /
   MISSION_REQUEST_INT / MISSION_ITEM_INT / MISSION_ACK;
4. wait for health: SYS_STATUS with the PREARM_CHECK bit and the GPS bit healthy, and at least
   2 s of simulated time since the parameters were set (PX4 picks up a changed output function
   on a later cycle; arming at once left the sprayer unmapped);
5. arm (COMMAND_LONG 400; a non-ACCEPTED COMMAND_ACK -> AutopilotError with PX4's result and
   its recent STATUSTEXT), then DO_SET_MODE AUTO.MISSION (176: 1, 4, 4);
6. follow HEARTBEAT (mode, armed), MISSION_CURRENT, MISSION_ITEM_REACHED and
   EXTENDED_SYS_STATE (landed state): the run is complete when the last item was reached (or
   the mission state is COMPLETE) and, if the mission lands, PX4 reports on-ground and disarmed.
   Once PX4 has flown in Mission mode, a switch to any other mode before the mission is done
   (a failsafe: geofence Hold, RTL, Land...) is a ``failsafe`` event whose cause is PX4's latest
   warning STATUSTEXT, and ends the run with status ``failsafe``, except the switch to RTL that the
   mission's own last item (NAV_RETURN_TO_LAUNCH) makes: PX4 executes it as its RTL mode (judged when PX4's
   reports show that item, within :data:`RTL_REPORT_GRACE_US`), so the mission is then complete once PX4 is
   on the ground and disarmed. PX4 v1.15 sends HEARTBEAT at 1 Hz
   and refuses a faster interval, so the switch is heard up to 1 s of flight after PX4 acted. A PX4 on the
   ground and disarmed after flying, before the mission's last item (a land item before the end), flies no
   further: after :data:`EARLY_LANDING_GRACE_US` the run ends as ``aborted``, naming the item reached.

The client sends a GCS HEARTBEAT every second of wall time *or* of sim time, whichever comes
first, so PX4's data-link-loss check (sim time) is satisfied at any speed-up.
"""

from __future__ import annotations

import logging
import math
import struct
import threading
import time
from typing import Any

from vinecli.autopilot.base import AutopilotContext, RunStatus
from vinecli.constants import STANDARD_GRAVITY
from vinecli.errors import AutopilotError, AutopilotTimeout, VinecliError
from vinecli.mavlink import px4modes as M
from vinecli.mavlink.link import UdpLink
from vinecli.mavlink.mission_items import MissionItem
from vinecli.mavlink.px4params import mission_params
from vinecli.phase_items import DO_SET_ACTUATOR, ItemPlan, phases_to_items
from vinecli.sitl.converter import converter_inputs, takeoff_mass_kg
from vinecli.specs.vehicle import VehicleSpec

log = logging.getLogger(__name__)

INT_PARAMS = frozenset({"GF_ACTION", "NAV_DLL_ACT", "COM_RC_IN_MODE"})
SEVERITY_WARNING = 4  # MAV_SEVERITY: 0 EMERGENCY ... 4 WARNING
#: PX4 picks up a changed output function (the sprayer's PWM_MAIN_FUNCn) on a later cycle; arming
#: ~0.05 s (simulated) after the PARAM_SETs left the sprayer unmapped for the whole flight in 2 of 3
#: runs (PX4 v1.15.4, seed 606006878), never with this delay. Arm no earlier than this after them.
PARAM_SETTLE_US = 2_000_000
#: wall s a parameter's confirmation is waited for at least, sent again every 1 s of PX4's clock (3 sends alone were
#: too few when the lockstep outran PX4's starved MAVLink thread: at load 8-10 EKF2_HGT_REF went unconfirmed)
PARAM_WALL_S = 10.0
#: PX4 on the ground and disarmed before the mission's end for this long (simulated; its MISSION_CURRENT and
#: HEARTBEAT come at 1 Hz) ends the run as aborted: it will not fly on
EARLY_LANDING_GRACE_US = 3_000_000
#: a switch to RTL before PX4 reported the mission's last navigation item is judged this long after (simulated):
#: MISSION_CURRENT (1 Hz) or MISSION_ITEM_REACHED may follow the HEARTBEAT showing the mission's own closing RTL
RTL_REPORT_GRACE_US = 2_000_000
#: wall seconds a wait for PX4's answer lasts at most when the simulation does not move (its limit is simulated time)
WAIT_WALL_S = 15.0


def battery_params(v: VehicleSpec, mass_kg: float) -> dict[str, float | int]:
    """PX4's battery from the vehicle's pack: the warning, critical and emergency charge thresholds, and PX4's
    SITL battery simulator draining over the pack's hover endurance (capacity / electrical hover power of
    vinecli's motor model). PX4 1.15 takes an external battery over MAVLink only without a remaining flight
    time, which its flight-time failsafe reads as none left at take-off, so its own simulator stays."""
    from vinecli.flight.battery import ElectricalLoad

    b = v.battery
    if b is None:
        return {}
    thrust = mass_kg * STANDARD_GRAVITY / v.n_rotors
    shaft = v.n_rotors * v.motor.k_m * thrust * math.sqrt(thrust / v.motor.k_f)
    endurance_s = b.capacity_wh * 3600.0 / ElectricalLoad(b, None).power_w(shaft, 0.0)
    return {"BAT_LOW_THR": b.low_soc, "BAT_CRIT_THR": b.critical_soc, "BAT_EMERGEN_THR": b.emergency_soc,
            "SIM_BAT_DRAIN": round(endurance_s, 1), "SIM_BAT_MIN_PCT": round(100.0 * b.emergency_soc, 1)}


def plan_for(ctx: AutopilotContext) -> ItemPlan:
    """The PX4 plan (items, fence, parameters) for ``ctx.mission`` (SpecError if PX4 cannot fly it): the
    items of :func:`vinecli.phase_items.phases_to_items` with the sprayer on DO_SET_ACTUATOR (set 1)."""
    v = ctx.vehicle
    mission, pc = converter_inputs(ctx, firmware="PX4")
    plan = phases_to_items(mission, pc, sprayer=DO_SET_ACTUATOR)
    plan.params = {**v.px4.params, **mission_params(mission)}  # the airframe's, then the mission's
    plan.params.update(battery_params(v, takeoff_mass_kg(ctx)))
    if any(it.command == M.CMD_DO_SET_ACTUATOR for it in plan.items):
        plan.params[f"PWM_MAIN_FUNC{v.px4.sprayer_channel + 1}"] = 301
    return plan


class Px4MissionClient:
    """GCS-side mission control of PX4 in a background thread (see the module docstring)."""

    # parameters: keyword-only options, each with its default (PX4's ports and time-outs); a caller names the ones it sets
    def __init__(self, plan: ItemPlan | None, ctx: AutopilotContext, *, host: str = "127.0.0.1", api_port: int = 14540,
                 px4_port: int = 14580, target_system: int = 1, heartbeat_timeout_s: float = 60.0,
                 health_timeout_s: float = 120.0, command_timeout_s: float = 1.0) -> None:
        self.plan = plan
        self.ctx = ctx
        self.target = target_system
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.health_timeout_s = health_timeout_s
        self.command_timeout_s = command_timeout_s
        self.sim_time_us = 0
        self.error: VinecliError | None = None
        self.finished: tuple[RunStatus, str] | None = None
        self.mode_name = "BOOT"
        self.armed = False
        self.current_seq = 0
        self.phase_index = 0
        self.landed_state = M.LANDED_UNDEFINED
        self.mission_state = 0
        self.reached: set[int] = set()
        self.statustext: list[str] = []
        self.sys_status: Any = None
        self.version_msg: Any = None  # AUTOPILOT_VERSION: PX4's version and git hash
        self.battery_warnings = 0  # PX4 warnings (STATUSTEXT <= WARNING) about its battery
        self._events: list[tuple[str, str, dict[str, object]]] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._hb_wall = 0.0
        self._hb_sim = -10**12
        self.was_airborne = False
        self.started = False
        self.in_mission = False
        self.rtl_item = False  # PX4 flies the mission's closing NAV_RETURN_TO_LAUNCH as its RTL mode
        self._rtl_pending: tuple[int, str] | None = None  # (sim µs, PX4's warnings) of a switch to RTL, unjudged
        self.warnings: list[tuple[float, str]] = []  # (wall time, text) of STATUSTEXT <= WARNING
        self._chunks: dict[int, str] = {}
        # state messages are handled in the link's reader thread as they arrive, so the run sees a
        # mission item change within a few ms of wall time (not when this client's thread is next scheduled)
        self.link = UdpLink((host, api_port), (host, px4_port), reply_to_sender=True, src_system=255, src_component=190,
                            on_message=self._handle)

    # ------------------------------------------------------------------ thread control
    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="px4-mission", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self.link.close()  # its reader first (woken at once), while this client's thread sees the stop flag
        if self._thread is not None:
            self._thread.join(timeout=2.0)

    def drain_events(self) -> list[tuple[str, str, dict[str, object]]]:
        with self._lock:
            ev, self._events = self._events, []
        return ev

    def _event(self, kind: str, msg: str, data: dict[str, object] | None = None) -> None:
        log.info("%s: %s", kind, msg)
        with self._lock:
            self._events.append((kind, msg, data or {}))

    def _run(self) -> None:
        try:
            self._sequence()
        except VinecliError as exc:
            self.error = exc
        except Exception as exc:  # noqa: BLE001 - surfaced as an AutopilotError in step()
            self.error = AutopilotError(f"PX4 mission control failed: {type(exc).__name__}: {exc}")

    # ------------------------------------------------------------------ receive helpers
    def _tick(self) -> None:
        now = time.monotonic()
        if now - self._hb_wall >= 1.0 or self.sim_time_us - self._hb_sim >= 1_000_000:
            self._hb_wall, self._hb_sim = now, self.sim_time_us
            self.link.send(self.link.mav.heartbeat_encode(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, M.MAV_STATE_ACTIVE))

    def _handle(self, m: Any) -> None:
        typ = m.get_type()
        if m.get_srcSystem() != self.target and typ != "BAD_DATA":
            return
        if typ == "HEARTBEAT" and m.get_srcComponent() == 1:
            armed = bool(m.base_mode & M.MODE_FLAG_SAFETY_ARMED)
            main, sub = M.decode_custom_mode(m.custom_mode)
            name = M.mode_name(main, sub)
            if name != self.mode_name:
                self._event("mode", name, {"mode": name, "previous": self.mode_name})
                self.mode_name = name
                self._check_mode(name)
            if armed != self.armed:
                self.armed = armed
                self._event("arming", "armed" if armed else "disarmed", {"armed": armed})
        elif typ == "STATUSTEXT":
            text = self._statustext(m)
            if text is None:
                return
            self.statustext.append(text)
            del self.statustext[:-10]
            self._event("px4_statustext", text, {"severity": int(m.severity)})
            if int(m.severity) <= SEVERITY_WARNING:
                self.warnings.append((time.monotonic(), text))
                del self.warnings[:-10]
                self.battery_warnings += "batt" in text.lower()
        elif typ == "SYS_STATUS":
            self.sys_status = m
        elif typ == "AUTOPILOT_VERSION":
            self.version_msg = m
        elif typ == "MISSION_CURRENT":
            if m.seq != self.current_seq:
                self.current_seq = m.seq
                self._set_phase(m.seq)
            self.mission_state = getattr(m, "mission_state", 0)
        elif typ == "MISSION_ITEM_REACHED":
            if m.seq not in self.reached:
                self.reached.add(m.seq)
                self._event("mission_item_reached", f"item {m.seq} reached", {"seq": int(m.seq)})
        elif typ == "EXTENDED_SYS_STATE":
            if m.landed_state != self.landed_state:
                self.landed_state = m.landed_state
                names = {1: "on_ground", 2: "in_air", 3: "takeoff", 4: "landing"}
                self._event("landed_state", names.get(m.landed_state, "undefined"), {"landed_state": int(m.landed_state)})
                if m.landed_state in (M.LANDED_IN_AIR, M.LANDED_TAKEOFF, M.LANDED_LANDING):  # a short hop: never in_air
                    self.was_airborne = True

    def _statustext(self, m: Any) -> str | None:
        """The text of a STATUSTEXT, chunks (same non-zero ``id``, 50 characters each) joined; None mid-message."""
        raw = m.text if isinstance(m.text, str) else m.text.decode(errors="replace")
        raw = raw.split("\x00", 1)[0]
        sid = int(getattr(m, "id", 0) or 0)
        if sid:
            raw = self._chunks.pop(sid, "") + raw
            if len(raw) % 50 == 0 and raw:  # a full chunk: more follow
                self._chunks[sid] = raw
                return None
        return raw.strip()

    def _check_mode(self, name: str) -> None:
        """Once the mission runs, PX4 leaving Mission mode is a failsafe (or an operator): end the run."""
        if not self.started or self.finished is not None:
            return
        if name == "mission":
            self.in_mission = True
            return
        if not self.in_mission or (self.mission_done() and name in ("hold", "ready")):
            return
        if self.rtl_item and self.landed_state == M.LANDED_ON_GROUND and not self.armed:
            return  # returned and disarmed: the mission's end, whatever mode PX4 shows next
        if name == "rtl":
            if self._at_rtl_item():
                self._rtl_is_the_mission_s()
            elif self._rtl_pending is None:  # judged by _judge_rtl once PX4's reports had time to arrive
                self._rtl_pending = (self.sim_time_us, self.failsafe_cause())
            return
        self._failsafe(name)

    def _rtl_is_the_mission_s(self) -> None:
        self._rtl_pending = None
        if not self.rtl_item:
            self.rtl_item = True
            self._event("mission_rtl", f"PX4 returns to launch: the mission's last item {self.current_seq}",
                        {"seq": self.current_seq})

    def _judge_rtl(self) -> None:
        """A pending RTL: the mission's closing item once PX4 reports it there, else a failsafe (grace over)."""
        pending = self._rtl_pending
        if pending is None or self.finished is not None:
            return
        if self.mode_name == "rtl" and self._at_rtl_item():
            self._rtl_is_the_mission_s()
        elif self.mode_name != "rtl" or self.sim_time_us - pending[0] >= RTL_REPORT_GRACE_US:
            self._rtl_pending = None
            self._failsafe("rtl", pending[1])

    def _failsafe(self, name: str, cause: str | None = None) -> None:
        """PX4 left the mission for mode ``name``: a failsafe, caused by PX4's latest warning (or ``cause``)."""
        cause = self.failsafe_cause() if cause is None else cause
        data: dict[str, object] = {"cause": cause, "action": name, "mode": name, "seq": self.current_seq}
        self._event("failsafe", f"PX4 left the mission: {cause} -> {name}", data)
        self.finished = (RunStatus.FAILSAFE, f"PX4 failsafe: {cause} -> {name} (mission item {self.current_seq})")

    def failsafe_cause(self) -> str:
        """PX4's latest warning (STATUSTEXT severity <= WARNING) of the last 5 s, else a plain mode change."""
        recent: list[str] = []
        for w, t in self.warnings:
            if time.monotonic() - w < 5.0 and t not in recent:
                recent.append(t)
        return "; ".join(recent) if recent else f"mode changed from mission to {self.mode_name}"

    def _at_rtl_item(self) -> bool:
        """PX4 is at the mission's closing NAV_RETURN_TO_LAUNCH: it is the current item, PX4 reported it reached,
        or PX4 reached the last navigation item before it or an item after that (PX4 may report only a DO item
        between them, and MISSION_CURRENT may arrive after the mode change)."""
        items = self.plan.items if self.plan is not None else []
        last = len(items) - 1
        if last < 0 or items[last].command != M.CMD_NAV_RETURN_TO_LAUNCH:
            return False
        nav_before = max((i for i in range(last) if items[i].command < 100), default=-1)  # MAV_CMD_NAV_* < 100
        # PX4 may report only a DO item after the last navigation item reached (item 27 of 29, never 26)
        return self.current_seq == last or max(self.reached, default=-1) >= max(nav_before, 0)

    def mission_done(self) -> bool:
        """The last item was reached (or PX4 reports the mission complete)."""
        n = len(self.plan.items) if self.plan is not None else 0
        return (n - 1) in self.reached or self.mission_state == M.MISSION_STATE_COMPLETE

    def _set_phase(self, seq: int) -> None:
        if self.plan is not None and 0 <= seq < len(self.plan.phase_of_item):
            pi = self.plan.phase_of_item[seq]
            if pi >= 0 and pi != self.phase_index:
                self.phase_index = pi
                self._event("phase", f"phase {pi} (item {seq})", {"index": pi, "seq": seq})

    def _wait(self, types: set[str], timeout: float, cond: Any = None) -> Any:
        """The first matching message within ``timeout`` s of PX4's clock (the simulation's: on a loaded machine
        PX4 answers in simulated time, seconds of wall time later), or None; :data:`WAIT_WALL_S` of wall time
        without it ends the wait too (a simulation that does not move)."""
        sim_deadline = self.sim_time_us + int(timeout * 1e6)
        wall_deadline = time.monotonic() + max(timeout, WAIT_WALL_S)
        while not self._stop.is_set():
            self._tick()
            left = wall_deadline - time.monotonic()
            if left <= 0 or self.sim_time_us >= sim_deadline:
                return None
            m = self.link.recv(min(left, 0.1))
            if m is None:
                continue
            if m.get_type() in types and m.get_srcSystem() == self.target and (cond is None or cond(m)):
                return m
        return None

    # ------------------------------------------------------------------ protocol pieces
    def command(self, cmd: int, *params: float, retries: int = 3) -> Any:
        """COMMAND_LONG and its COMMAND_ACK (None if never acknowledged)."""
        p = list(params) + [0.0] * (7 - len(params))
        for attempt in range(retries):
            self.link.send(self.link.mav.command_long_encode(self.target, 1, cmd, attempt, *p))
            ack = self._wait({"COMMAND_ACK"}, self.command_timeout_s, lambda a: a.command == cmd)
            if ack is not None:
                return ack
        return None

    def set_param(self, name: str, value: float | int) -> None:
        is_int = isinstance(value, int) or name in INT_PARAMS or name.startswith("PWM_")
        wire, ptype = (struct.unpack("<f", struct.pack("<i", int(value)))[0], 6) if is_int else (float(value), 9)
        tries, give_up = 0, time.monotonic() + PARAM_WALL_S
        while not self._stop.is_set() and (tries < 3 or time.monotonic() < give_up):
            tries += 1
            self.link.send(self.link.mav.param_set_encode(self.target, 1, name.encode(), wire, ptype))
            pv = self._wait({"PARAM_VALUE"}, self.command_timeout_s, lambda m: _pname(m) == name)
            if pv is not None:
                return
        raise AutopilotError(f"PX4 did not confirm parameter {name} = {value}")

    def upload(self, items: list[MissionItem], mission_type: int) -> None:
        """MISSION_COUNT -> answer each MISSION_REQUEST(_INT) -> MISSION_ACK (AutopilotError if rejected)."""
        what = {0: "mission", 1: "geofence", 2: "rally points"}[mission_type]
        mav = self.link.mav
        n = len(items)
        self.link.send(mav.mission_count_encode(self.target, 1, n, mission_type))
        deadline = time.monotonic() + 5.0 + 0.5 * n
        while time.monotonic() < deadline:
            m = self._wait({"MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"}, 2.0,
                           lambda x: getattr(x, "mission_type", 0) == mission_type)
            if m is None:
                self.link.send(mav.mission_count_encode(self.target, 1, n, mission_type))
                continue
            if m.get_type() == "MISSION_ACK":
                if m.type != 0:
                    raise AutopilotError(f"PX4 rejected the {what} upload: MISSION_ACK {_mission_result(m.type)}"
                                         + self._px4_says())
                self._event("mission_uploaded", f"{what} uploaded ({n} items)", {"mission_type": mission_type, "count": n})
                return
            if not 0 <= m.seq < n:
                raise AutopilotError(f"PX4 requested {what} item {m.seq} of {n}")
            self.link.send(items[m.seq].encode(mav, m.seq, self.target, 1, current=1 if m.seq == 0 else 0))
        raise AutopilotTimeout(f"PX4 {what} upload timed out" + self._px4_says())

    def _px4_says(self) -> str:
        said = self.warnings[-1][1] if self.warnings else (self.statustext[-1] if self.statustext else "")
        return f" (PX4: {said!r})" if said else ""

    # ------------------------------------------------------------------ the sequence
    def _sequence(self) -> None:
        hb = self._wait({"HEARTBEAT"}, self.heartbeat_timeout_s, lambda m: m.get_srcComponent() == 1)
        if self._stop.is_set():
            return
        if hb is None:
            raise AutopilotTimeout(
                f"no HEARTBEAT from PX4 (system {self.target}) on UDP {self.link.local[0]}:{self.link.local[1]} within "
                f"{self.heartbeat_timeout_s:g} s (PX4's API link sends to 14540+instance)")
        if hb.autopilot != M.MAV_AUTOPILOT_PX4:
            log.warning("the API peer reports autopilot type %d, not PX4 (12)", hb.autopilot)
        self._event("px4_link", "PX4 API link up", {"port": self.link.local[1]})
        self.link.send(self.link.mav.command_long_encode(self.target, 1, M.CMD_REQUEST_MESSAGE, 0, 148, 0, 0, 0, 0, 0, 0))
        plan = self.plan
        if plan is None:
            return
        for name, value in plan.params.items():
            self.set_param(name, value)
        params_sim_us = self.sim_time_us
        self.upload(plan.items, M.MAV_MISSION_TYPE_MISSION)
        if plan.fence:
            self.upload(plan.fence, M.MAV_MISSION_TYPE_FENCE)
        self._wait_health()
        self._wait_sim(params_sim_us + PARAM_SETTLE_US)
        ack = self.command(M.CMD_COMPONENT_ARM_DISARM, 1.0)
        if ack is None:
            raise AutopilotTimeout("PX4 did not acknowledge the arm command" + self._px4_says())
        if ack.result != M.MAV_RESULT_ACCEPTED:
            self._wait({"STATUSTEXT"}, 0.3)
            raise AutopilotError(f"PX4 rejected arming: {M.MAV_RESULT_NAMES.get(ack.result, ack.result)}" + self._px4_says())
        ack = self.command(M.CMD_DO_SET_MODE, 1.0, M.MAIN_AUTO, M.SUB_MISSION)
        if ack is None or ack.result != M.MAV_RESULT_ACCEPTED:
            res = "no answer" if ack is None else M.MAV_RESULT_NAMES.get(ack.result, str(ack.result))
            raise AutopilotError(f"PX4 did not start the mission (DO_SET_MODE AUTO.MISSION: {res})" + self._px4_says())
        self.started = True
        self._event("mission_start", "mission started", {})
        self._monitor()

    def _wait_sim(self, until_us: int) -> None:
        """Let simulated time reach ``until_us`` (the run keeps stepping; wall-clock bounded)."""
        deadline = time.monotonic() + self.health_timeout_s
        while self.sim_time_us < until_us and time.monotonic() < deadline and not self._stop.is_set():
            self._wait(set(), 0.02)

    def _wait_health(self) -> None:
        deadline = time.monotonic() + self.health_timeout_s
        need = M.SENSOR_PREARM_CHECK | 32
        while time.monotonic() < deadline and not self._stop.is_set():
            m = self._wait({"SYS_STATUS"}, 1.0)
            if m is not None and (m.onboard_control_sensors_health & need) == need:
                self._event("px4_health", "PX4 pre-arm checks pass", {})
                return
        if not self._stop.is_set():
            raise AutopilotTimeout(f"PX4 did not become ready to arm within {self.health_timeout_s:g} s" + self._px4_says())

    def _landed_early(self, n: int) -> None:
        """PX4 is on the ground and disarmed, the mission not done: it will not fly on (a land item before the end,
        a landing PX4 decided itself): the run ends now as ``aborted``, naming the item it reached."""
        text = _landed_early_text(self.current_seq, n, self.reached)
        self._event("mission_aborted", text, {"seq": self.current_seq, "items": n})
        self.finished = (RunStatus.ABORTED, text)

    def _monitor(self) -> None:
        plan = self.plan
        assert plan is not None
        lands = bool(plan.items) and plan.items[-1].command in (M.CMD_NAV_LAND, M.CMD_NAV_RETURN_TO_LAUNCH)
        down_since: int | None = None  # sim µs since PX4 is on the ground and disarmed before the mission's end
        while not self._stop.is_set() and self.finished is None:
            self._wait(set(), 0.2)
            self._judge_rtl()
            done_items = self.mission_done()
            if self.finished is not None:
                return
            if self.was_airborne and self.landed_state == M.LANDED_ON_GROUND and not self.armed \
                    and not (done_items or self.rtl_item):
                down_since = self.sim_time_us if down_since is None else down_since
                if self.sim_time_us - down_since >= EARLY_LANDING_GRACE_US:  # its last reports had time to arrive
                    self._landed_early(len(plan.items))
                    return
            else:
                down_since = None
            if lands:  # complete only when PX4 reported the last item done and is on the ground, disarmed
                if (done_items or self.rtl_item) and self.was_airborne and self.landed_state == M.LANDED_ON_GROUND \
                        and not self.armed:
                    how = "returned to launch, " if self.rtl_item else ""
                    self.finished = (RunStatus.COMPLETED, f"PX4 mission completed, {how}landed and disarmed")
                    return
            elif done_items:
                self.finished = (RunStatus.COMPLETED, "PX4 mission completed")
                return


def _landed_early_text(seq: int, n: int, reached: set[int]) -> str:
    last = f"last reported reached: item {max(reached)}" if reached else "no item reported reached"
    return f"PX4 landed and disarmed before the mission's end: at mission item {seq} of {n} ({last})"


def _pname(m: Any) -> str:
    pid = m.param_id
    return (pid.decode(errors="replace") if isinstance(pid, bytes) else pid).rstrip("\x00")


def _mission_result(code: int) -> str:
    names = {0: "ACCEPTED", 1: "ERROR", 2: "UNSUPPORTED_FRAME", 3: "UNSUPPORTED", 4: "NO_SPACE", 5: "INVALID",
             13: "INVALID_SEQUENCE", 14: "DENIED", 15: "OPERATION_CANCELLED"}
    return names.get(code, str(code))


__all__ = ["Px4MissionClient", "plan_for"]
