"""The vehicle side of MAVLink: what QGroundControl, MAVSDK and pymavlink expect from PX4.

:class:`VehicleEndpoint` speaks the protocol over a :class:`~vinecli.mavlink.link.UdpLink`
(sysid = instance + 1, compid 1, MAVLink 2) and delegates decisions to a handler
(:class:`VehicleHandler`). Call :meth:`VehicleEndpoint.update` regularly (every physics step):
it answers everything received and sends periodic telemetry.

Sent (docs/firmware-protocols.md §3): HEARTBEAT 1 Hz (type 2, autopilot 12, base_mode 1 | 128
armed, PX4 custom_mode; re-sent at once on mode/arm changes), SYS_STATUS 1 Hz (gyro, accel,
mag, baro, GPS and PREARM_CHECK bits), GLOBAL_POSITION_INT 10 Hz, GPS_RAW_INT 5 Hz, ATTITUDE
and ATTITUDE_QUATERNION 10 Hz, EXTENDED_SYS_STATE 1 Hz, HOME_POSITION 1 Hz (and on request),
MISSION_CURRENT 1 Hz, MISSION_ITEM_REACHED, AUTOPILOT_VERSION / PROTOCOL_VERSION on request,
STATUSTEXT. Periods count in the caller's clock (sim time) *or* wall time, whichever elapses
first, so clients' wall-clock time-outs hold at any speed-up.

Handled: COMMAND_LONG / COMMAND_INT -> always a COMMAND_ACK (unknown -> UNSUPPORTED), legacy
SET_MODE, the mission protocol (upload, download, clear, set current; types 0/1/2, each
stored separately) and the parameter protocol (list, read by name/index, set with echo).
"""

from __future__ import annotations

import logging
import math
import struct
import time
from dataclasses import dataclass, field
from typing import Any, Protocol

from vinecli.mavlink import px4modes as M
from vinecli.mavlink.link import Link
from vinecli.mavlink.mission_items import MissionItem, check_item

log = logging.getLogger(__name__)
NAN = float("nan")

#: supported commands besides the handler's; everything else -> MAV_RESULT_UNSUPPORTED
CAPABILITIES = 2 | 4 | 8 | 8192 | 16384 | 32768  # PARAM_FLOAT, MISSION_INT, COMMAND_INT, MAVLINK2, FENCE, RALLY
FLIGHT_SW_VERSION = (1 << 24) | (15 << 16) | (0 << 8) | 255  # reports "1.15.0 release"-style PX4 semantics


@dataclass
class Telemetry:
    """Vehicle state for the outgoing messages (NED/FRD at this boundary)."""

    armed: bool = False
    mode: str = "hold"  # key of px4modes.MODES
    landed_state: int = M.LANDED_ON_GROUND
    lat: float = 0.0  # deg
    lon: float = 0.0
    alt_amsl: float = 0.0  # m
    rel_alt: float = 0.0  # m above home
    vel_ned: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m/s
    q_wxyz: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)  # NED <- FRD
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)  # rad, NED/FRD Euler
    rates_frd: tuple[float, float, float] = (0.0, 0.0, 0.0)  # rad/s
    home: tuple[float, float, float] = (0.0, 0.0, 0.0)  # lat, lon deg, alt m AMSL
    gps_fix: int = 3
    satellites: int = 12
    eph_m: float = 0.3
    prearm_ok: bool = True
    position_ok: bool = True  # the position estimate is usable (GPS bit healthy)
    mission_seq: int = 0
    mission_state: int = M.MISSION_STATE_NOT_STARTED
    battery_pct: int = 100
    time_boot_ms: int = 0


class VehicleHandler(Protocol):
    """What the endpoint asks the vehicle. Return a MAV_RESULT (0 accepted)."""

    def on_arm(self, arm: bool, force: bool) -> tuple[int, str]: ...
    def on_mode(self, mode: str) -> int: ...
    def on_takeoff(self, alt_rel_m: float | None) -> int: ...
    def on_land(self) -> int: ...
    def on_rtl(self) -> int: ...
    def on_mission_start(self) -> int: ...
    def on_reposition(self, lat: float, lon: float, alt_amsl: float, speed: float) -> int: ...
    def on_set_actuator(self, u: float) -> int: ...
    def on_change_speed(self, speed: float) -> int: ...
    def on_mission(self, mission_type: int, items: list[MissionItem]) -> None: ...
    def on_set_current(self, seq: int) -> int: ...
    def on_param(self, name: str, value: float) -> None: ...


@dataclass
class _Upload:
    mission_type: int
    count: int
    items: list[MissionItem] = field(default_factory=list)
    peer: tuple[int, int] = (255, 0)
    last_req: float = 0.0


class VehicleEndpoint:
    """MAVLink vehicle on ``link`` (see the module docstring). ``params``: name -> value (int = INT32)."""

    def __init__(self, link: Link, handler: VehicleHandler, params: dict[str, float | int] | None = None,
                 *, sysid: int = 1, uid: int = 0x56494E45) -> None:
        self.link, self.handler, self.sysid, self.uid = link, handler, sysid, uid
        self.params: dict[str, float | int] = dict(params or {})
        self.missions: dict[int, list[MissionItem]] = {0: [], 1: [], 2: []}
        self._upload: _Upload | None = None
        self._last: dict[str, tuple[float, float]] = {}  # name -> (clock s, wall s)
        self._periods = {"hb": 1.0, "sys": 1.0, "pos": 0.1, "gps": 0.2, "att": 0.1, "ext": 1.0, "home": 1.0, "mcur": 1.0}
        self._hb_key: tuple[bool, str] | None = None
        self.tel = Telemetry()
        self.received: list[str] = []  # message types seen (for tests/diagnostics)
        self.commands: list[int] = []
        self.gcs_seen = False

    # ------------------------------------------------------------------ main entry
    def update(self, now_s: float, tel: Telemetry) -> None:
        """Answer everything received, then send what is due at ``now_s`` (caller's clock, s)."""
        self.tel = tel
        for m in self.link.drain():
            try:
                self._handle(m)
            except Exception as exc:  # noqa: BLE001 - one bad message must not stop the vehicle
                log.warning("MAVLink %s from %d/%d not handled: %s", m.get_type(), m.get_srcSystem(), m.get_srcComponent(), exc)
        up = self._upload
        if up is not None and time.monotonic() - up.last_req > 0.5:
            self._request(up)
        key = (tel.armed, tel.mode)
        if key != self._hb_key:
            self._hb_key = key
            self._last.pop("hb", None)
        wall = time.monotonic()
        for name, period in self._periods.items():
            last = self._last.get(name)
            if last is None or now_s - last[0] >= period or wall - last[1] >= period or now_s < last[0]:
                self._last[name] = (now_s, wall)
                self._send_periodic(name, tel)

    def send_state_now(self, tel: Telemetry) -> None:
        """HEARTBEAT and EXTENDED_SYS_STATE right away (after an arm/mode change inside a step)."""
        self.tel = tel
        self._hb_key = (tel.armed, tel.mode)
        wall = time.monotonic()
        for name in ("hb", "ext"):
            self._last[name] = (self._last.get(name, (0.0, wall))[0], wall)
            self._send_periodic(name, tel)

    def statustext(self, text: str, severity: int = 6) -> None:
        """Send a STATUSTEXT (≤ 50 chars)."""
        self.link.send(self.link.mav.statustext_encode(severity, text[:50].encode()))

    def mission_item_reached(self, seq: int) -> None:
        self.link.send(self.link.mav.mission_item_reached_encode(seq))

    # ------------------------------------------------------------------ periodic telemetry
    def _send_periodic(self, name: str, t: Telemetry) -> None:
        mav = self.link.mav
        send = self.link.send
        if name == "hb":
            main, sub = M.MODES.get(t.mode, (M.MAIN_AUTO, M.SUB_LOITER))
            base = M.MODE_FLAG_CUSTOM | (M.MODE_FLAG_SAFETY_ARMED if t.armed else 0) | (4 if main == M.MAIN_AUTO else 0)
            state = M.MAV_STATE_ACTIVE if t.armed else M.MAV_STATE_STANDBY
            send(mav.heartbeat_encode(M.MAV_TYPE_QUADROTOR, M.MAV_AUTOPILOT_PX4, base, M.custom_mode(main, sub), state))
        elif name == "sys":
            health = M.SENSORS_BASIC | (M.SENSOR_PREARM_CHECK if t.prearm_ok else 0)
            if t.gps_fix < 3 or not t.position_ok:  # MAVSDK derives "global/local position ok" from this bit
                health &= ~32
            present = M.SENSORS_BASIC | M.SENSOR_PREARM_CHECK
            send(mav.sys_status_encode(present, present, health, 200, 16200, -1, t.battery_pct, 0, 0, 0, 0, 0, 0))
        elif name == "pos":
            hdg = round(math.degrees(t.rpy[2]) % 360.0 * 100) % 36000
            vn, ve, vd = t.vel_ned
            send(mav.global_position_int_encode(
                t.time_boot_ms, round(t.lat * 1e7), round(t.lon * 1e7), round(t.alt_amsl * 1000), round(t.rel_alt * 1000),
                _i16(vn * 100), _i16(ve * 100), _i16(vd * 100), hdg))
            send(mav.local_position_ned_encode(t.time_boot_ms, *self._local_ned(t), vn, ve, vd))
        elif name == "gps":
            vn, ve, _ = t.vel_ned
            gs = math.hypot(vn, ve)
            send(mav.gps_raw_int_encode(
                t.time_boot_ms * 1000, t.gps_fix, round(t.lat * 1e7), round(t.lon * 1e7), round(t.alt_amsl * 1000),
                max(1, round(t.eph_m * 100)), max(1, round(t.eph_m * 150)), round(gs * 100), 65535 if gs < 0.2 else
                round(math.degrees(math.atan2(ve, vn)) % 360 * 100) % 36000, t.satellites))
        elif name == "att":
            r, p, y = t.rpy
            send(mav.attitude_encode(t.time_boot_ms, r, p, y, *t.rates_frd))
            send(mav.attitude_quaternion_encode(t.time_boot_ms, *t.q_wxyz, *t.rates_frd))
        elif name == "ext":
            send(mav.extended_sys_state_encode(0, t.landed_state))
        elif name == "home":
            self._send_home(t)
        elif name == "mcur":
            n = len(self.missions[0])
            send(mav.mission_current_encode(min(t.mission_seq, max(0, n - 1)) if n else 0, n, t.mission_state, 0))

    def _local_ned(self, t: Telemetry) -> tuple[float, float, float]:
        m_lat = 111_132.0
        m_lon = 111_320.0 * math.cos(math.radians(t.home[0]))
        return ((t.lat - t.home[0]) * m_lat, (t.lon - t.home[1]) * m_lon, -(t.alt_amsl - t.home[2]))

    def _send_home(self, t: Telemetry) -> None:
        lat, lon, alt = t.home
        self.link.send(self.link.mav.home_position_encode(round(lat * 1e7), round(lon * 1e7), round(alt * 1000),
                                                          0.0, 0.0, 0.0, (1.0, 0.0, 0.0, 0.0), 0.0, 0.0, 0.0))

    # ------------------------------------------------------------------ dispatch
    def _handle(self, m: Any) -> None:
        typ = m.get_type()
        self.received.append(typ)
        if len(self.received) > 2000:
            del self.received[:1000]
        tgt = getattr(m, "target_system", None)
        if tgt not in (None, 0, self.sysid):
            return
        if typ == "HEARTBEAT":
            if m.type == M.MAV_TYPE_GCS:
                self.gcs_seen = True
        elif typ in ("COMMAND_LONG", "COMMAND_INT"):
            try:
                self._command(m)
            except Exception as exc:  # noqa: BLE001 - every command gets an ACK, even a failed one
                log.warning("command %d failed: %s", m.command, exc)
                self._ack(m, m.command, M.MAV_RESULT_FAILED)
        elif typ == "SET_MODE":
            main, sub = M.decode_custom_mode(m.custom_mode)
            self.handler.on_mode(M.mode_name(main, sub))
        elif typ.startswith("MISSION_") or typ == "MISSION_ITEM":
            self._mission(m, typ)
        elif typ.startswith("PARAM_"):
            self._param(m, typ)

    # ------------------------------------------------------------------ commands
    def _ack(self, m: Any, cmd: int, result: int) -> None:
        self.link.send(self.link.mav.command_ack_encode(cmd, result, 0, 0, m.get_srcSystem(), m.get_srcComponent()))

    def _command(self, m: Any) -> None:
        cmd = m.command
        self.commands.append(cmd)
        p = (m.param1, m.param2, m.param3, m.param4)
        if m.get_type() == "COMMAND_INT":
            p5, p6, p7 = m.x * 1e-7, m.y * 1e-7, m.z
        else:
            p5, p6, p7 = m.param5, m.param6, m.param7
        h = self.handler
        if cmd == M.CMD_COMPONENT_ARM_DISARM:
            res, text = h.on_arm(p[0] >= 0.5, _int(p[1]) == M.ARM_FORCE_MAGIC)
            if text:
                self.statustext(text, 4 if res else 6)
            self._ack(m, cmd, res)
        elif cmd == M.CMD_NAV_TAKEOFF:
            alt = None
            if math.isfinite(p7) and p7 != 0.0:
                alt = p7 - self.tel.home[2]  # PX4 semantics: AMSL altitude
            self._ack(m, cmd, h.on_takeoff(alt))
        elif cmd == M.CMD_NAV_LAND:
            self._ack(m, cmd, h.on_land())
        elif cmd == M.CMD_NAV_RETURN_TO_LAUNCH:
            self._ack(m, cmd, h.on_rtl())
        elif cmd == M.CMD_DO_SET_MODE:
            if _int(p[0]) & M.MODE_FLAG_CUSTOM:
                name = M.mode_name(_int(p[1]), _int(p[2]))
                res = M.MAV_RESULT_DENIED if name.startswith("unknown") else h.on_mode(name)
            else:
                res = M.MAV_RESULT_UNSUPPORTED
            self._ack(m, cmd, res)
            self._last.pop("hb", None)
        elif cmd == M.CMD_MISSION_START:
            self._ack(m, cmd, h.on_mission_start())
        elif cmd == M.CMD_DO_REPOSITION:
            self._ack(m, cmd, h.on_reposition(p5, p6, p7, p[0]))
        elif cmd == M.CMD_DO_CHANGE_SPEED:
            self._ack(m, cmd, h.on_change_speed(p[1]))
        elif cmd == M.CMD_DO_SET_ACTUATOR:
            self._ack(m, cmd, h.on_set_actuator(p[0]) if math.isfinite(p[0]) else M.MAV_RESULT_ACCEPTED)
        elif cmd == M.CMD_DO_SET_MISSION_CURRENT:
            self._ack(m, cmd, h.on_set_current(_int(p[0], -1)))
        elif cmd == M.CMD_SET_MESSAGE_INTERVAL:
            names = {33: "pos", 24: "gps", 30: "att", 31: "att", 245: "ext", 242: "home", 42: "mcur", 1: "sys", 0: "hb"}
            key = names.get(_int(p[0]))
            if key is not None and p[1] > 0 and key != "hb":
                self._periods[key] = max(0.01, p[1] * 1e-6)
            self._ack(m, cmd, M.MAV_RESULT_ACCEPTED)
        elif cmd in (M.CMD_REQUEST_MESSAGE, M.CMD_REQUEST_AUTOPILOT_CAPABILITIES, M.CMD_REQUEST_PROTOCOL_VERSION):
            want = _int(p[0]) if cmd == M.CMD_REQUEST_MESSAGE else (148 if cmd == M.CMD_REQUEST_AUTOPILOT_CAPABILITIES else 300)
            known = {148, 300, 242, 0, 1, 245, 33, 24}
            self._ack(m, cmd, M.MAV_RESULT_ACCEPTED if want in known else M.MAV_RESULT_UNSUPPORTED)
            self._emit_requested(want)
        elif cmd == M.CMD_DO_SET_HOME:
            self._ack(m, cmd, M.MAV_RESULT_DENIED)
        else:
            self._ack(m, cmd, M.MAV_RESULT_UNSUPPORTED)

    def _emit_requested(self, msg_id: int) -> None:
        mav = self.link.mav
        if msg_id == 148:
            self.link.send(mav.autopilot_version_encode(CAPABILITIES, FLIGHT_SW_VERSION, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8,
                                                        0x56, 0x1, self.uid))
        elif msg_id == 300:
            # PROTOCOL_VERSION (300) is missing from pymavlink's common dialect: encode by hand (CRC extra 217)
            self.link.send_raw(300, 217, struct.pack("<HHH8s8s", 200, 100, 200, bytes(8), bytes(8)))
        elif msg_id == 242:
            self._send_home(self.tel)
        else:
            name = {0: "hb", 1: "sys", 245: "ext", 33: "pos", 24: "gps"}.get(msg_id)
            if name is not None:
                self._send_periodic(name, self.tel)

    # ------------------------------------------------------------------ missions
    def _mission(self, m: Any, typ: str) -> None:
        mav = self.link.mav
        src = (m.get_srcSystem(), m.get_srcComponent())
        mt = getattr(m, "mission_type", 0)
        if typ in ("MISSION_COUNT", "MISSION_REQUEST_LIST", "MISSION_CLEAR_ALL") and mt not in (0, 1, 2):
            self.link.send(mav.mission_ack_encode(*src, M.MAV_MISSION_UNSUPPORTED, mt))
            return
        if typ == "MISSION_COUNT":
            if m.count == 0:
                self.missions[mt] = []
                self.handler.on_mission(mt, [])
                self.link.send(mav.mission_ack_encode(*src, M.MAV_MISSION_ACCEPTED, mt))
                return
            self._upload = _Upload(mt, m.count, peer=src)
            self._request(self._upload)
        elif typ in ("MISSION_ITEM_INT", "MISSION_ITEM"):
            up = self._upload
            if up is None or mt != up.mission_type:
                return
            if m.seq != len(up.items):
                if m.seq < len(up.items):
                    return  # duplicate
                self.link.send(mav.mission_ack_encode(*up.peer, M.MAV_MISSION_INVALID_SEQUENCE, mt))
                self._upload = None
                return
            it = MissionItem.from_msg(m)
            res = check_item(it) if mt == 0 else (M.MAV_MISSION_ACCEPTED if 5000 <= it.command <= 5100 else M.MAV_MISSION_UNSUPPORTED)
            if res != M.MAV_MISSION_ACCEPTED:
                self.link.send(mav.mission_ack_encode(*up.peer, res, mt))
                self.statustext(f"Mission item {m.seq}: command {it.command} rejected", 4)
                self._upload = None
                return
            up.items.append(it)
            if len(up.items) == up.count:
                self.missions[mt] = up.items
                self._upload = None
                self.link.send(mav.mission_ack_encode(*up.peer, M.MAV_MISSION_ACCEPTED, mt))
                self.handler.on_mission(mt, up.items)
            else:
                self._request(up)
        elif typ == "MISSION_REQUEST_LIST":
            self.link.send(mav.mission_count_encode(*src, len(self.missions[mt]), mt))
        elif typ in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            items = self.missions.get(mt, [])
            if 0 <= m.seq < len(items):
                self.link.send(items[m.seq].encode(mav, m.seq, src[0], src[1], current=int(m.seq == self.tel.mission_seq)))
            else:
                self.link.send(mav.mission_ack_encode(*src, M.MAV_MISSION_INVALID_SEQUENCE, mt))
        elif typ == "MISSION_CLEAR_ALL":
            self.missions[mt] = []
            self.handler.on_mission(mt, [])
            self.link.send(mav.mission_ack_encode(*src, M.MAV_MISSION_ACCEPTED, mt))
        elif typ == "MISSION_SET_CURRENT":
            self.handler.on_set_current(int(m.seq))
        # MISSION_ACK from a client ends a download: nothing to do

    def _request(self, up: _Upload) -> None:
        up.last_req = time.monotonic()
        self.link.send(self.link.mav.mission_request_int_encode(*up.peer, len(up.items), up.mission_type))

    # ------------------------------------------------------------------ parameters
    def _param_value(self, name: str, index: int) -> None:
        v = self.params[name]
        if isinstance(v, int) and not isinstance(v, bool):
            wire, ptype = struct.unpack("<f", struct.pack("<i", v))[0], 6
        else:
            wire, ptype = float(v), 9
        self.link.send(self.link.mav.param_value_encode(name.encode(), wire, ptype, len(self.params), index))

    def _param(self, m: Any, typ: str) -> None:
        names = list(self.params)
        if typ == "PARAM_REQUEST_LIST":
            for i, n in enumerate(names):
                self._param_value(n, i)
        elif typ == "PARAM_REQUEST_READ":
            if m.param_index >= 0:
                if m.param_index < len(names):
                    self._param_value(names[m.param_index], m.param_index)
                return
            name = _pid(m.param_id)
            if name in self.params:
                self._param_value(name, names.index(name))
        elif typ == "PARAM_SET":
            name = _pid(m.param_id)
            if name not in self.params:
                self.statustext(f"unknown parameter {name}", 4)
                return
            old = self.params[name]
            if isinstance(old, int) and not isinstance(old, bool):
                val: float | int = struct.unpack("<i", struct.pack("<f", m.param_value))[0] if m.param_type == 6 else int(m.param_value)
            else:
                val = float(m.param_value)
            self.params[name] = val
            self.handler.on_param(name, float(val))
            self._param_value(name, names.index(name))


def _int(x: float, default: int = 0) -> int:
    """int() of a command parameter that may be NaN (MAVSDK sends NaN for 'unused')."""
    return int(x) if math.isfinite(x) else default


def _pid(pid: Any) -> str:
    if isinstance(pid, bytes):
        pid = pid.decode(errors="replace")
    return str(pid).rstrip("\x00")


def _i16(x: float) -> int:
    return 0 if not math.isfinite(x) else max(-32767, min(32767, round(x)))


DEFAULT_PARAMS: dict[str, float | int] = {
    "MIS_TAKEOFF_ALT": 2.5,
    "RTL_RETURN_ALT": 5.0,
    "MPC_XY_CRUISE": 5.0,
    "MPC_TKO_SPEED": 1.5,
    "MPC_LAND_SPEED": 0.7,
    "NAV_MC_ALT_RAD": 0.8,
    "MPC_Z_V_AUTO_UP": 3.0,
    "MPC_TKO_RAMP_T": 3.0,
    "EKF2_HGT_REF": 1,
    "EKF2_GPS_CTRL": 7,
    "GF_ACTION": 2,
    "GF_MAX_HOR_DIST": 0.0,
    "GF_MAX_VER_DIST": 0.0,
    "NAV_DLL_ACT": 0,
    "COM_RC_IN_MODE": 1,
    "PWM_MAIN_FUNC9": 301,
    "SYS_AUTOSTART": 10016,
    # PX4's battery failsafe thresholds and its SITL battery simulator (PX4 v1.15 defaults); vinecli's PX4
    # bridge sets them from the vehicle's pack (vinecli.sitl.px4.mission_client.battery_params)
    "BAT_LOW_THR": 0.15,
    "BAT_CRIT_THR": 0.07,
    "BAT_EMERGEN_THR": 0.05,
    "SIM_BAT_DRAIN": 60.0,
    "SIM_BAT_MIN_PCT": 50.0,
}
